"""What a body formula keeps of the plan library for the event it posts itself.

`!g`, `+b` and `-b` post an event of one fixed key (operator, functor, arity,
negation) on their own intention, and `Runtime.intend_now` usually handles it in the
same step. Looking the key up per step (its compiled selection, whether it has plans,
whether a `-!g` plan forbids the tail-recursion optimisation) costs two dictionary
lookups of a tuple key, which Python hashes anew each time: about a fifth of a cycle
of `+!count(I, N) : I < N <- !count(I + 1, N).` An `OwnEvent` keeps those answers
for the formula and asks again only when the library has changed (`PlanLibrary.version`)
or is another agent's.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

from mrss.agentspeak.terms import DEL_ACH

# A formula's own event (`!g`, `+b`, `-b`) is handled in its step when that is the same
# as through the queue (`Runtime.intend_now`, and its forms written out in
# `instructions`); False sends every event through the queue: the reference the tests
# compare the at-once handling with. (A module global: read on every such step, it is
# cheaper here than as a class attribute read through the agent.)
AT_ONCE = True

if TYPE_CHECKING:
    from mrss.agentspeak.plans import PlanKey, PlanLibrary
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
