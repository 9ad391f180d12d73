"""What a recorded mission told its reasoner, and what the reasoner decided: the input of
a what-if replay (whatif.py), read from a recording in order.

* **inputs**, timed by the recorder's clock: percepts (add, remove; one a message id, as
  the reasoner takes them), a robot becoming unavailable or available again (the
  reasoner's `robot_unavailable(R)`: `robot.<id>.state`, `sup.quarantine`/`release`),
  and each action's outcome (its first terminal `action.status`);
* the **decisions** the recorded reasoner took: its `action.request`s, each once;
* the data layer's **answers** to the reasoner's queries (`dl.request` from the reasoner
  and their `dl.reply`), by function and arguments.
"""

from __future__ import annotations

import enum
import json
from collections.abc import Iterable
from dataclasses import dataclass, field
from typing import Any

from mrss.messages import (
    ActionRequest,
    ActionState,
    ActionStatus,
    DataReply,
    DataRequest,
    Envelope,
    Percept,
    RobotState,
    SupEvent,
    SupEventKind,
)

TERMINAL = frozenset({ActionState.SUCCEEDED, ActionState.FAILED, ActionState.CANCELLED})


class InputKind(enum.StrEnum):
    """What the reasoner is told, in recorded order."""

    ADD = "add"          # a percept
    REMOVE = "remove"    # a percept no longer held
    REQUESTED = "requested"  # the recorded reasoner asked for an action (not an input:
                             # where the edited one is compared)
    OUTCOME = "outcome"  # an action ended


@dataclass(frozen=True)
class Decision:
    """One environment action the reasoner asked for."""

    at: float  # seconds since the recording's first message
    name: str
    args: tuple[Any, ...]
    text: str  # name(args), as AgentSpeak prints it

    @property
    def robot(self) -> str:
        return str(self.args[0]) if self.args else ""


@dataclass(frozen=True)
class Input:
    at: float
    kind: InputKind
    literal: str = ""  # ADD / REMOVE
    uuid: str = ""  # REQUESTED / OUTCOME
    ok: bool = True  # OUTCOME
    cause: str = ""  # OUTCOME: a failure's cause


@dataclass
class Timeline:
    """A recording as its reasoner saw it."""

    inputs: list[Input] = field(default_factory=list)
    decisions: dict[str, Decision] = field(default_factory=dict)  # uuid -> decision
    answers: dict[tuple[str, str], list[tuple[float, bool, Any]]] = field(
        default_factory=dict)  # (function, args JSON) -> [(at, ok, result)]
    span: float = 0.0


def args_key(args: Any) -> str:
    return json.dumps(args, sort_keys=True, separators=(",", ":"), default=str)


def timeline(messages: Iterable[tuple[Envelope, float]], reasoner: str = "reasoner"
             ) -> Timeline:
    """The timeline of `(envelope, recorded at)` pairs in recorded order; `reasoner` is
    the reasoner's component id (its requests, its queries)."""
    found = Timeline()
    seen: set[tuple[str, str]] = set()
    ended: set[str] = set()
    queries: dict[str, DataRequest] = {}
    unavailable: dict[str, bool] = {}
    start: float | None = None
    for env, at in messages:
        start = at if start is None else start
        t = at - start
        found.span = max(found.span, t)
        key = (env.src, env.id)
        if key in seen:
            continue
        seen.add(key)
        body = env.body
        if isinstance(body, Percept):
            kind = InputKind.ADD if body.op == "add" else InputKind.REMOVE
            found.inputs.append(Input(t, kind, literal=body.literal))
        elif isinstance(body, ActionRequest):
            if body.uuid not in found.decisions:
                found.decisions[body.uuid] = Decision(t, body.name, tuple(body.args),
                                                      body.literal or _text(body))
                found.inputs.append(Input(t, InputKind.REQUESTED, uuid=body.uuid))
        elif isinstance(body, ActionStatus):
            if body.state in TERMINAL and body.uuid not in ended:
                ended.add(body.uuid)
                found.inputs.append(Input(t, InputKind.OUTCOME, uuid=body.uuid,
                                          ok=body.state is ActionState.SUCCEEDED,
                                          cause=body.cause.value or body.state.value))
        elif isinstance(body, RobotState) or (
                isinstance(body, SupEvent) and body.event in (SupEventKind.QUARANTINE,
                                                              SupEventKind.RELEASE)):
            robot, down = _availability(body)
            if robot and unavailable.get(robot, False) != down:
                unavailable[robot] = down
                found.inputs.append(Input(t, InputKind.ADD if down else InputKind.REMOVE,
                                          literal=f"robot_unavailable({robot})"))
        elif isinstance(body, DataRequest) and env.src == reasoner:
            queries[body.request_id] = body
        elif isinstance(body, DataReply):
            request = queries.pop(body.request_id, None)
            if request is not None:
                found.answers.setdefault((request.function, args_key(request.args)), []) \
                    .append((t, body.ok, body.result))
    return found


def _availability(body: RobotState | SupEvent) -> tuple[str, bool]:
    if isinstance(body, RobotState):
        return body.robot, not body.available
    robot = body.detail.get("robot")
    return (robot if isinstance(robot, str) else ""), body.event is SupEventKind.QUARANTINE


def _text(request: ActionRequest) -> str:
    return f"{request.name}({','.join(map(str, request.args))})"
