"""ProgressFeed: which actions' progress is due to go out, at most once every `every` s each.

A skill's `record_progress` is journaled at once but is not a transition, so no status
goes out for it. Observers (the dashboard) still want to see a running action move:
the RCL publishes the latest progress as an `ActionStatus` marked `repeat` (the
current state sent again, never a transition), throttled per action. The first value
after a quiet period goes out at once; later ones wait until `every` seconds have
passed since the last one sent, and only the newest is sent (`take_due`, called from
the RCL's heartbeat, sends what waited). Pure bookkeeping: the RCL publishes.
"""

from __future__ import annotations

import threading
import time
from collections.abc import Callable
from typing import Any


class ProgressFeed:
    """Per-action throttle of progress statuses; `every <= 0` turns the feed off."""

    def __init__(self, every: float = 1.0,
                 clock: Callable[[], float] = time.monotonic) -> None:
        self.every = every
        self._clock = clock
        self._lock = threading.Lock()
        self._waiting: dict[str, dict[str, Any]] = {}  # uuid -> the newest progress
        self._sent: dict[str, float] = {}  # uuid -> when its progress last went out

    @property
    def enabled(self) -> bool:
        return self.every > 0

    def record(self, uuid: str, progress: dict[str, Any]) -> None:
        """`uuid` has new progress; it goes out with the next `take_due` that finds it due."""
        if not self.enabled:
            return
        with self._lock:
            self._waiting[uuid] = dict(progress)

    def take_due(self) -> dict[str, dict[str, Any]]:
        """The waiting progress whose action sent none in the last `every` s (taken)."""
        now = self._clock()
        with self._lock:
            due = {u: p for u, p in self._waiting.items()
                   if now - self._sent.get(u, -float("inf")) >= self.every}
            for uuid in due:
                del self._waiting[uuid]
                self._sent[uuid] = now
        return due

    def forget(self, uuid: str) -> None:
        """The action ended: nothing more of it goes out."""
        with self._lock:
            self._waiting.pop(uuid, None)
            self._sent.pop(uuid, None)

    def __len__(self) -> int:
        with self._lock:
            return len(self._waiting)
