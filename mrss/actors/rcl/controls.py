"""Pending controls: a control for a robot actor is journaled before it is delivered.

A control (a cancel, suspend, resume, succeed or fail, a pre-emption, a link loss) told
to a robot actor in the instant it crashes would be lost with its mailbox. Rules:
- the RCL journals every `Control` (its lifecycle event, as JSON) before telling it, and
  the message carries the journal's `seq`;
- a robot actor applies a control only while it is still pending in the journal, then
  marks it done (`claim`), so a control reaches the action exactly once even when it
  is both in the mailbox and read back from the journal;
- a robot actor's incarnation applies, at the end of its start hook (after taking its
  actions back), every control still pending for its robot, oldest first;
- a control for an action that is no longer active is marked done and ignored;
- compaction drops what is left pending for actions that ended (journal.compact).
"""

from __future__ import annotations

import json
from typing import Any

from mrss.actors.rcl import lifecycle as lc
from mrss.errors import DecodeError
from mrss.messages import ActionState

ControlEvent = lc.Suspend | lc.Resume | lc.End


def encode(event: ControlEvent) -> str:
    """The journal's text for a control's lifecycle event."""
    body: dict[str, Any] = {"kind": event.kind.value, "by": event.by.value}
    if isinstance(event, lc.Suspend):
        body["reason"] = event.reason
    elif isinstance(event, lc.Resume):
        body["teleop"] = event.teleop
    else:
        body.update(target=event.target.value, reason=event.reason, cause=event.cause)
    return json.dumps(body, sort_keys=True)


def decode(text: str) -> ControlEvent:
    """The lifecycle event journaled by `encode`; DecodeError names what is wrong."""
    try:
        body = json.loads(text)
        kind = lc.EventKind(body["kind"])
        if kind is lc.EventKind.SUSPEND:
            return lc.Suspend(lc.SuspendCause(body["by"]), str(body.get("reason", "")))
        if kind is lc.EventKind.RESUME:
            return lc.Resume(lc.SuspendCause(body["by"]), bool(body.get("teleop", False)))
        if kind is lc.EventKind.END:
            return lc.End(ActionState(body["target"]), lc.EndCause(body["by"]),
                          str(body.get("reason", "")), str(body.get("cause", "")))
    except (ValueError, KeyError, TypeError) as exc:
        raise DecodeError(f"journaled control {text!r}: {exc!r}") from exc
    raise DecodeError(f"journaled control {text!r}: expected a suspend, resume or end, "
                      f"got {kind.value}")
