"""A body formula's own event, handled in the formula's step.

`!g`, `+b` and `-b` post an event of one fixed key (operator, functor, arity,
negation) on their own intention, and when nothing else could tell the difference it
is handled in the same step (`Runtime.intend_now`): its plan selected and pushed, no
`Event`, no queue. Looking the key up per step (its compiled selection, whether it has
plans, whether a `-!g` plan forbids the tail-recursion optimisation) costs two
dictionary lookups of a tuple key, which Python hashes anew each time: about a fifth of
a cycle of `+!count(I, N) : I < N <- !count(I + 1, N).` An `OwnEvent` keeps those
answers for the formula and asks again only when the library has changed
(`PlanLibrary.version`) or is another agent's. `belief_event` is the at-once handling
of `+b`/`-b` with them (`!g`'s is written out in `instructions.Achieve`).
"""

from __future__ import annotations

from typing import TYPE_CHECKING

from mrss.agentspeak.intentions import PENDING_EVENT, Event, IntendedMeans
from mrss.agentspeak.terms import DEL_ACH, DEL_BEL, Struct

# A formula's own event (`!g`, `+b`, `-b`) is handled in its step when that is the same
# as through the queue (`Runtime.intend_now`, and its forms written out in
# `instructions`); False sends every event through the queue: the reference the tests
# compare the at-once handling with. (A module global: read on every such step, it is
# cheaper here than as a class attribute read through the agent.)
AT_ONCE = True

if TYPE_CHECKING:
    from mrss.agentspeak.intentions import Intention
    from mrss.agentspeak.plans import PlanKey, PlanLibrary
    from mrss.agentspeak.runtime import Runtime
    from mrss.agentspeak.selection import Selector


class OwnEvent:
    """The plan library's answers for one event key, valid for `lib` at `version`."""

    __slots__ = ("key", "lib", "version", "select", "relevant", "no_fail_plan")

    def __init__(self, key: PlanKey) -> None:
        self.key = key
        self.lib: PlanLibrary | None = None
        self.version = -1
        self.select: Selector | None = None
        self.relevant = False       # the key has plans
        self.no_fail_plan = False   # no `-!` plan for the goal (the tail-call rule)

    def refresh(self, plans: PlanLibrary) -> None:
        """Ask `plans` again (call when `lib is not plans or version != plans.version`)."""
        key = self.key
        try:
            select = plans.selectors[key]
        except KeyError:
            select = plans.selector(key)
        self.select = select
        self.relevant = key in plans.index
        self.no_fail_plan = (DEL_ACH, key[1], key[2], key[3]) not in plans.index
        self.lib = plans
        self.version = plans.version


def belief_event(rt: Runtime, own: OwnEvent, lit: Struct, it: Intention) -> bool:
    """`Runtime.belief_changed(op, lit, it, True)` for the `+b`/`-b` formula whose
    `OwnEvent` is `own`: the same outcome, with the plan library's answers kept and
    `Runtime.intend_now` written out."""
    plans = rt.plans
    if own.lib is not plans or own.version != plans.version:
        own.refresh(plans)
    if own.relevant:
        if rt.on_percept_gone is None or own.key[0] != DEL_BEL:
            if (not rt.events and not rt.event_waiters and rt.atomic is None
                    and not plans.meta and AT_ONCE):
                # `Runtime.intend_now`, written out for a belief event of a known key
                errors = rt.extras.context_errors
                found = own.select(rt, lit, errors)  # type: ignore[misc]
                if type(found) is tuple and not errors:
                    chosen, frame = found
                    it.stack.append(IntendedMeans(chosen, frame, lit, own.key[0]))
                    if chosen.atomic:
                        rt.atomic = it
                    rt.make_runnable(it)
                    return True
                errors.clear()
            it.state = PENDING_EVENT
            rt.post(Event(own.key[0], lit, it))
            return False
    elif not rt.event_waiters and (rt.on_percept_gone is None or own.key[0] != DEL_BEL):
        return False
    return rt.belief_changed(own.key[0], lit, it, True)
