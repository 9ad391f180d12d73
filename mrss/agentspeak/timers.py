"""The agent's clock-driven events: `.wait` deadlines and `.at` events, in one heap.

The rules: a `.wait` with a timeout adds a deadline for its intention and wait token;
an `.at` adds an event to post at a clock time. Entries fall due in deadline order
(ties in the order added) when the clock reaches them (`expire_timers`, once a
reasoning cycle): a due `.at` posts its event (an achievement goal as a new goal, with
its goal state); a due `.wait` times out (`goals.wait_timeout`) unless that wait is
over already (another token now, or the intention dropped). Such stale entries are
skipped: `next_deadline`, the clock time the agent must wake next, drops them as it
meets them.
"""

from __future__ import annotations

import heapq
from typing import TYPE_CHECKING

from mrss.agentspeak import goals
from mrss.agentspeak.intentions import Event, Intention
from mrss.agentspeak.terms import ADD_ACH

if TYPE_CHECKING:
    from mrss.agentspeak.runtime import Runtime


def add_timer(rt: Runtime, deadline: float, it: Intention, token: int) -> None:
    heapq.heappush(rt.timers, (deadline, next(rt._seq), it, token))


def add_event_at(rt: Runtime, deadline: float, ev: Event) -> None:
    """Post `ev` when the clock reaches `deadline` (`.at`)."""
    heapq.heappush(rt.timers, (deadline, next(rt._seq), None, ev))


def next_deadline(rt: Runtime) -> float | None:
    """The earliest `.wait` deadline (clock seconds), skipping stale timers."""
    timers = rt.timers
    while timers:
        _, _, it, token = timers[0]
        if it is None or (it.wait is not None and it.wait.token == token
                          and not it.dropped):
            return timers[0][0]
        heapq.heappop(timers)
    return None


def expire_timers(rt: Runtime, now: float) -> bool:
    fired = False
    timers = rt.timers
    while timers and timers[0][0] <= now:
        _, _, it, token = heapq.heappop(timers)
        if it is None:  # `.at`: its event is due
            if token.op == ADD_ACH:
                rt.post_goal(token.lit, None)
            else:
                rt.post(token)
            fired = True
        elif it.wait is not None and it.wait.token == token and not it.dropped:
            goals.wait_timeout(rt, it, now)
            fired = True
    return fired
