"""One timer thread for every link of a process: a heap of deadlines.

A link that must act without incoming data (send its controller heartbeat, notice that
telemetry stopped) schedules a job here instead of running a thread of its own: with
100 links, one thread wakes at the earliest deadline instead of 100 threads polling.

A job is a function returning the seconds until it wants to run again, or None when it
is done. Jobs run one at a time on the timer thread: they must return quickly (no
waiting on a robot). A job that raises is logged and runs again a second later, so a
bug cannot silence a link's watchdog for good. The thread starts with the first job and
ends when the last job is cancelled or done (it is a daemon thread).
"""

from __future__ import annotations

import heapq
import itertools
import logging
import threading
import time
from collections.abc import Callable

Job = Callable[[], "float | None"]

RETRY_AFTER_ERROR_S = 1.0
THREAD_NAME = "mrss-link-timers"


class TimerHandle:
    """One scheduled job; `cancel()` stops it (it may be running right now)."""

    __slots__ = ("_owner", "cancelled", "job", "name")

    def __init__(self, owner: Timers, job: Job, name: str) -> None:
        self._owner = owner
        self.job = job
        self.name = name
        self.cancelled = False

    def cancel(self) -> None:
        """Run the job no more (a run under way finishes); the thread drops it."""
        self.cancelled = True
        self._owner.wake()


class Timers:
    """A heap of (deadline, job) served by one thread, started and ended on demand."""

    def __init__(self, name: str = THREAD_NAME) -> None:
        self.name = name
        self.log = logging.getLogger("mrss.links.timers")
        self._cond = threading.Condition()
        self._heap: list[tuple[float, int, TimerHandle]] = []
        self._seq = itertools.count()
        self._thread: threading.Thread | None = None

    def schedule(self, job: Job, delay: float = 0.0, name: str = "job") -> TimerHandle:
        """Run `job` after `delay` seconds, then again after each delay it returns."""
        handle = TimerHandle(self, job, name)
        with self._cond:
            heapq.heappush(self._heap, (time.monotonic() + max(delay, 0.0),
                                        next(self._seq), handle))
            if self._thread is None:
                self._thread = threading.Thread(target=self._run, name=self.name,
                                                daemon=True)
                self._thread.start()
            elif self._heap[0][2] is handle:
                self._cond.notify()
        return handle

    def wake(self) -> None:
        """Make the thread look at the heap now (after a cancel)."""
        with self._cond:
            self._cond.notify()

    @property
    def jobs(self) -> int:
        """Scheduled jobs not cancelled or done."""
        with self._cond:
            return sum(1 for _, _, h in self._heap if not h.cancelled)

    @property
    def running(self) -> bool:
        """Whether the timer thread runs."""
        with self._cond:
            return self._thread is not None

    def _run(self) -> None:
        while True:
            with self._cond:
                while True:
                    while self._heap and self._heap[0][2].cancelled:
                        heapq.heappop(self._heap)
                    if not self._heap:
                        self._thread = None  # the next schedule() starts a new one
                        return
                    deadline, _, handle = self._heap[0]
                    wait = deadline - time.monotonic()
                    if wait <= 0:
                        heapq.heappop(self._heap)
                        break
                    self._cond.wait(wait)
            again = self._call(handle)
            if again is not None and not handle.cancelled:
                with self._cond:
                    heapq.heappush(self._heap, (time.monotonic() + max(again, 0.0),
                                                next(self._seq), handle))

    def _call(self, handle: TimerHandle) -> float | None:
        if handle.cancelled:
            return None
        try:
            return handle.job()
        except Exception:
            self.log.exception("link timer job %s failed; it runs again in %.0f s",
                               handle.name, RETRY_AFTER_ERROR_S)
            return RETRY_AFTER_ERROR_S


#: The process's shared link timers.
TIMERS = Timers()
