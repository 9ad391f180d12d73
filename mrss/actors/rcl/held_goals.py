"""Goals held by goal management: a suspended goal stays suspended for later actions too.

The rule: `suspend` by goal holds that goal until a `resume`, `cancel`, `succeed` or
`fail` by goal releases it. An action requested for a held goal meanwhile starts
SUSPENDED (by the agent if the one who held the goal is its requester, else by the
operator) instead of running: the agent (or operator) suspended the goal, not only the
actions that happened to exist at that moment.

Why: an agent decides on goals, and its requests go out a step behind its decisions. A
scheduler that starts goal a1 and, before a1's action is requested, pre-empts it for a
higher one (two goals perceived together; a restarted reasoner perceiving every durable
goal at once; a low battery at that moment) sends `suspend a1` while the RCL has nothing
for a1. Without this rule a1's action would then run although the agent holds a1.

Only the last `MAX_HELD` goals are remembered (goal ids are unbounded over a long
mission). Held goals live in the RCL process: a goal held with no action for it yet is
forgotten by an RCL restart (its actions, once requested, are journaled with their
suspension like any other).
"""

from __future__ import annotations

from collections import OrderedDict

from mrss.actors.rcl.lifecycle import SuspendCause

MAX_HELD = 10_000
HOLD, RELEASE = frozenset({"suspend"}), frozenset({"resume", "cancel", "succeed", "fail"})


class HeldGoals:
    """Goals suspended by goal management, with who suspended them (a component name)."""

    def __init__(self, limit: int = MAX_HELD) -> None:
        self._by: OrderedDict[str, str] = OrderedDict()
        self._limit = limit

    def control(self, command: str, goal: str, src: str) -> None:
        """A goal-management command by goal, from `src`."""
        if command in HOLD:
            self._by.pop(goal, None)
            self._by[goal] = src
            while len(self._by) > self._limit:
                self._by.popitem(last=False)
        elif command in RELEASE:
            self._by.pop(goal, None)

    def cause_for(self, goal: str, requester: str) -> SuspendCause | None:
        """How a new action of `goal` requested by `requester` starts: suspended by whom,
        or None (it runs)."""
        if not goal or goal not in self._by:
            return None
        src = self._by[goal]
        return SuspendCause.AGENT if src and src == requester else SuspendCause.OPERATOR
