"""`.at(When, Event)`: post an event later, timed by the agent's clock (as `.wait`)."""

from __future__ import annotations

import re
from typing import Any

from mrss.agentspeak.intentions import Event
from mrss.agentspeak.registry import IAContext
from mrss.agentspeak.stdlib import STDLIB
from mrss.agentspeak.termorder import add_annot
from mrss.agentspeak.terms import ADD_ACH, Struct, Trigger, deref, is_number, term_str, value

# Jason's time units in `.at("now +3 minutes", ...)`, in seconds
UNITS = {"ms": 0.001, "millisecond": 0.001, "milliseconds": 0.001, "s": 1.0, "second": 1.0,
         "seconds": 1.0, "m": 60.0, "minute": 60.0, "minutes": 60.0, "h": 3600.0,
         "hour": 3600.0, "hours": 3600.0, "d": 86400.0, "day": 86400.0, "days": 86400.0}
_WHEN = re.compile(r"\s*now\s*(?:\+\s*(\d+(?:\.\d+)?)\s*([a-z]*)\s*)?$")


def delay_seconds(ctx: IAContext, when: Any) -> float:
    """The delay `When` stands for: a number of milliseconds, or a string
    `"now +N unit"` (unit ms, s, m, h or d, also spelt out; milliseconds if none)."""
    if is_number(when):
        return float(when) / 1000.0
    if type(when) is str:
        m = _WHEN.match(when)
        if m is not None:
            if m.group(1) is None:
                return 0.0
            unit = m.group(2) or "ms"
            if unit in UNITS:
                return float(m.group(1)) * UNITS[unit]
    raise ctx.error(f'the time must be a number of milliseconds or a string "now +N unit" '
                    f'(unit ms, s, m, h or d), not {term_str(when)}')


@STDLIB.action(".at", min_args=2, max_args=2)
def at(ctx: IAContext, args: list[Any]) -> bool:
    """`.at("now +2 s", {+!g})`: the event `+!g` is posted 2 s from now (a new
    intention handles it, as an external event)."""
    rt = ctx.runtime
    delay = delay_seconds(ctx, deref(args[0]))
    ev = value(args[1])
    if type(ev) is not Trigger or type(ev.lit) is not Struct:
        raise ctx.error(f"the event must be a triggering event such as {{+!g}}, "
                        f"not {term_str(ev)}")
    lit = ev.lit
    if ev.op == ADD_ACH and not any(type(a) is Struct and a.functor == "source"
                                    for a in lit.annots):
        lit = Struct(lit.functor, lit.args,
                     add_annot(lit.annots, Struct("source", (Struct("self"),))), lit.neg)
    rt.add_event_at(rt.clock() + delay, Event(ev.op, lit, None))
    return True
