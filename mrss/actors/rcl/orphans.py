"""Orphans: actions whose requester died, waiting to be adopted by its next incarnation.

The rules (the RCL core applies them; this module holds the bookkeeping):
1. When a requester shows a newer incarnation, each open action of its older ones is an
   orphan, due for cancellation after the grace: `grace` seconds for a running or
   pending action (it keeps its robot busy), `grace_suspended` for a suspended one.
2. A request from the newer incarnation with an orphan's uuid adopts it: it is no
   orphan any more, whatever its state.
3. An orphan whose grace is over is cancelled (cause `orphaned`), once.
4. The inventory a new incarnation asks for lists what its predecessors left: their
   open actions, and those that ended within `grace` seconds (their outcome may never
   have reached the dead incarnation).
"""

from __future__ import annotations

import time
from collections.abc import Callable
from typing import Any

from mrss.actors.rcl.journal import ActionJournal
from mrss.messages import ActionState


class Orphans:
    """Due times of orphaned actions; not thread-safe (the RCL core's lock guards it)."""

    def __init__(self, grace: float = 10.0, grace_suspended: float = 120.0,
                 clock: Callable[[], float] = time.monotonic) -> None:
        self.grace, self.grace_suspended = grace, grace_suspended
        self._clock = clock
        self._due: dict[str, float] = {}  # uuid -> when it is cancelled if not adopted

    def add(self, uuid: str, state: ActionState) -> float:
        """Rule 1: `uuid` is an orphan now; returns its grace in seconds."""
        grace = self.grace_suspended if state is ActionState.SUSPENDED else self.grace
        self._due.setdefault(uuid, self._clock() + grace)
        return grace

    def adopted(self, uuid: str) -> None:
        """Rule 2."""
        self._due.pop(uuid, None)

    def take_due(self) -> list[str]:
        """Rule 3: the orphans whose grace is over, forgotten as they are returned."""
        now = self._clock()
        due = [u for u, t in self._due.items() if t <= now]
        for uuid in due:
            del self._due[uuid]
        return due

    def inventory(self, journal: ActionJournal, requester: str,
                  inc: int) -> list[dict[str, Any]]:
        """Rule 4, as the plain items of an `ActionInventory`."""
        left = journal.left_by(requester, inc, time.time() - self.grace)
        return [{"uuid": e.action.uuid, "literal": e.action.literal, "goal": e.action.goal,
                 "robot": e.action.robot, "state": e.action.state.value,
                 "reason": e.action.reason, "cause": e.action.cause} for e in left]

    def __len__(self) -> int:
        return len(self._due)
