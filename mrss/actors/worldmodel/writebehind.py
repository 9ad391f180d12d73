"""Write-behind for telemetry: many object updates committed in one transaction.

A robot's telemetry (position, speed, battery) reaches the world model as writes nobody
waits for (`wm.upsert` sent with `send`, `WorldModel.upsert(..., deferred=True)`). With
PostGIS a transaction per update costs a commit (a WAL flush) and several round trips;
`WriteBehind` keeps such updates and has them committed together:

- `stage(obj)` merges the update into the object as this process last saw it (its own
  pending updates included, else read from the store) and returns that `Change` at once;
  the update is queued in arrival order.
- The queue is committed in one transaction (`commit(updates)`, in order: each object's
  updates keep their order) when `size` updates are pending, `interval` seconds after the
  first one was queued (a thread of its own), before any read or acknowledged write of
  the store (`flush()`: a read never misses what was staged before it), and at `close()`.
- Durability: a staged update is not acknowledged to anyone; it is committed within
  `interval` (or sooner). If the process dies (SIGKILL) what is pending is lost, at most
  `interval` seconds of telemetry. If the database is down the updates stay queued (up
  to `max_pending`; beyond it the oldest are dropped and counted in `dropped`) and are
  committed when it is back. Acknowledged writes (`upsert`) are unchanged: committed
  before they return, after the telemetry staged before them.
"""

from __future__ import annotations

import logging
import threading
import time
from collections.abc import Callable

from mrss.actors.worldmodel.store import WorldStoreUnavailable
from mrss.world.objects import Change, WorldObject, merge

log = logging.getLogger("mrss.worldmodel.writebehind")
Update = tuple[WorldObject, bool]  # (object, replace_attributes)
DEFAULT_SIZE = 200
DEFAULT_INTERVAL = 0.05
DEFAULT_MAX_PENDING = 100_000
_WARN_EVERY = 10.0


class WriteBehind:
    """Updates queued and committed in batches by `commit(updates)` (one transaction)."""

    def __init__(self, read: Callable[[str], WorldObject | None],
                 commit: Callable[[list[Update]], None], *, size: int = DEFAULT_SIZE,
                 interval: float = DEFAULT_INTERVAL,
                 max_pending: int = DEFAULT_MAX_PENDING) -> None:
        self._read, self._commit = read, commit
        self.size, self.interval, self.max_pending = max(1, size), interval, max_pending
        self._lock = threading.RLock()  # staging and flushing; never held while waiting
        self._wake = threading.Condition(self._lock)
        self._pending: list[Update] = []
        self._seen: dict[str, WorldObject] = {}  # objects as merged with pending updates
        self._first: float | None = None  # when the oldest pending update was queued
        self._closed = False
        self._last_warning = 0.0
        self.batches = 0
        self.committed = 0
        self.dropped = 0
        self._thread = threading.Thread(target=self._run, daemon=True,
                                        name="worldmodel-writebehind")
        self._thread.start()

    @property
    def pending(self) -> int:
        with self._lock:
            return len(self._pending)

    def stage(self, obj: WorldObject, *, replace_attributes: bool = False) -> Change:
        """Queue an update; its Change against what this process saw. WorldStoreUnavailable
        when the object had to be read and the database is down (nothing queued)."""
        with self._lock:
            base = self._seen[obj.id] if obj.id in self._seen else self._read(obj.id)
            change = merge(obj, base, replace_attributes=replace_attributes)
            if change.op == "unchanged":
                return change
            self._pending.append((obj, replace_attributes))
            self._seen[obj.id] = change.obj
            if self._first is None:
                self._first = time.monotonic()
                self._wake.notify()
            if len(self._pending) > self.max_pending:
                excess = len(self._pending) - self.max_pending
                del self._pending[:excess]
                self.dropped += excess
                self._warn(f"{excess} telemetry update(s) dropped: more than "
                           f"{self.max_pending} waiting for the database")
            if len(self._pending) >= self.size:
                self._try_flush()
            return change

    def flush(self) -> None:
        """Commit everything pending now; WorldStoreUnavailable if the database is down
        (the updates stay queued)."""
        with self._lock:
            if not self._pending:
                return
            batch = list(self._pending)
            self._commit(batch)
            del self._pending[:len(batch)]
            self._seen.clear()
            self._first = None
            self.batches += 1
            self.committed += len(batch)

    def _try_flush(self) -> bool:
        try:
            self.flush()
            return True
        except WorldStoreUnavailable as exc:
            self._warn(f"{len(self._pending)} telemetry update(s) wait for the database: "
                       f"{exc}")
            return False

    def _warn(self, text: str) -> None:
        now = time.monotonic()
        if now - self._last_warning >= _WARN_EVERY:
            self._last_warning = now
            log.warning("%s", text)

    def _run(self) -> None:
        with self._wake:
            while not self._closed:
                if self._first is None:
                    self._wake.wait()
                    continue
                left = self._first + self.interval - time.monotonic()
                if left > 0:
                    self._wake.wait(left)
                    continue
                if not self._try_flush():  # down: try again an interval later
                    self._first = time.monotonic()

    def close(self) -> None:
        """Commit what is pending (logged as lost if the database is down) and stop."""
        with self._wake:
            self._closed = True
            self._wake.notify()
            if self._pending and not self._try_flush():
                log.error("%d telemetry update(s) lost: the database is down at close",
                          len(self._pending))
        self._thread.join(timeout=5)
