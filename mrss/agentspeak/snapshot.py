"""A plain-data picture of an agent's mind (beliefs, intentions, events) for inspectors.

Everything in the result is str/int/bool/None/list/dict, so it can be JSON- or
msgpack-encoded and published as it is.
"""

from __future__ import annotations

from collections.abc import Callable, Hashable
from typing import TYPE_CHECKING, Any

from mrss.agentspeak.compile import plan_text
from mrss.agentspeak.intentions import IntendedMeans, Intention
from mrss.agentspeak.terms import OP_TEXT, term_str, value

if TYPE_CHECKING:
    from mrss.agentspeak.runtime import Runtime


def _frame(im: IntendedMeans) -> dict[str, str]:
    names = im.plan.varnames
    out: dict[str, str] = {}
    for i, v in enumerate(im.frame):
        if v is not None and i < len(names) and names[i] != "_":
            out[names[i]] = term_str(value(v))
    return out


def _next(im: IntendedMeans) -> str | None:
    code = im.code
    pc = im.pc
    while pc < len(code) and type(code[pc]).__name__ == "Jump":
        pc = code[pc].target
    return code[pc].text() if pc < len(code) else None


def intention_data(it: Intention,
                   action_id: Callable[[Hashable], Hashable] = lambda h: h) -> dict[str, Any]:
    """One intention: id, state, what it waits on, and its stack (top first).

    `action_id` names the action behind the host's handle as the outside world knows it
    (a restarted reasoner's action may have adopted another uuid than its handle)."""
    waiting: str | None = None
    if it.action is not None:
        waiting = f"action {action_id(it.action)!r}"
    elif it.wait is not None:
        waiting = f".wait {it.wait.text}"
    return {
        "id": it.id,
        "state": it.state,
        "suspended": it.suspended,
        "waiting_on": waiting,
        "stack": [
            {
                "trigger": OP_TEXT[im.op] + term_str(value(im.lit)),
                "plan": plan_text(im.plan),
                "source": f"{im.plan.file}:{im.plan.line}",
                "next": _next(im),
                "bindings": _frame(im),
            }
            for im in reversed(it.stack)
        ],
    }


def take_snapshot(rt: Runtime,
                  action_id: Callable[[Hashable], Hashable] = lambda h: h) -> dict[str, Any]:
    events = [ev for ev in list(rt.atomic_events) + list(rt.events)
              if ev.intention is None or (not ev.intention.dropped
                                          and ev.intention.gen == ev.gen)]
    return {
        "agent": rt.name,
        "cycle": rt.cycle,
        "beliefs": rt.bb.texts(),
        "intentions": [intention_data(it, action_id) for it in rt.intentions.values()],
        "events": [
            {"trigger": OP_TEXT[ev.op] + term_str(value(ev.lit)),
             "intention": ev.intention.id if ev.intention is not None else None}
            for ev in events
        ],
        "actions": [{"handle": repr(h), "intention": it.id}
                    for h, it in rt.pending_actions.items()],
    }
