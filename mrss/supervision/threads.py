"""Pre-started threads for actor loops, so restarting an actor does not wait for a thread.

pykka starts a new thread per actor and `Thread.start` waits until that thread runs;
on a busy machine this handshake is most of an actor restart. Supervised actors take a
thread from this pool instead: handing over the actor loop is a queue put, and a spare
is topped up without blocking. Pool threads are daemon threads: supervisors stop their
actors explicitly, which is how MRSS shuts down.
"""

from __future__ import annotations

import _thread
import heapq
import logging
import queue
import threading
import time
from collections.abc import Callable

log = logging.getLogger("mrss.supervision.threads")


class ThreadPool:
    """Runs callables on idle threads, keeping `spare` idle ones ready."""

    def __init__(self, spare: int = 2, idle_timeout: float = 60.0) -> None:
        self.spare = spare
        self.idle_timeout = idle_timeout
        self._tasks: queue.SimpleQueue[Callable[[], None]] = queue.SimpleQueue()
        self._lock = threading.Lock()
        self._idle = 0  # idle threads minus queued tasks

    def submit(self, task: Callable[[], None]) -> None:
        """Run `task` on a pool thread; never waits for a thread to start."""
        with self._lock:
            self._idle -= 1
            missing = max(0, self.spare - self._idle)
            self._idle += missing
        self._tasks.put(task)
        for _ in range(missing):
            _thread.start_new_thread(self._work, ())

    def _work(self) -> None:
        while True:
            try:
                task = self._tasks.get(timeout=self.idle_timeout)
            except queue.Empty:
                with self._lock:
                    if self._idle > self.spare:
                        self._idle -= 1
                        return
                continue
            try:
                task()
            except BaseException:  # an actor loop must never take a pool thread down
                log.exception("actor loop ended with an exception")
            finally:
                with self._lock:
                    self._idle += 1


ACTOR_THREADS = ThreadPool()


class Scheduled:
    """A pending call of the Scheduler; `cancel` stops it from running."""

    __slots__ = ("due", "fn", "cancelled")

    def __init__(self, due: float, fn: Callable[[], None]) -> None:
        self.due = due
        self.fn = fn
        self.cancelled = False

    def cancel(self) -> None:
        self.cancelled = True

    def __lt__(self, other: Scheduled) -> bool:
        return self.due < other.due


class Scheduler:
    """One thread running delayed calls (restart backoff, probation, start checks).

    Scheduling only wakes the thread when the new call is due before all others, so
    far-off checks cost nothing on the restart path.
    """

    def __init__(self) -> None:
        self._heap: list[Scheduled] = []
        self._cond = threading.Condition()
        self._thread: threading.Thread | None = None

    def call_later(self, delay: float, fn: Callable[[], None]) -> Scheduled:
        item = Scheduled(time.monotonic() + max(0.0, delay), fn)
        with self._cond:
            heapq.heappush(self._heap, item)
            if self._thread is None:
                self._thread = threading.Thread(target=self._run, name="mrss-scheduler",
                                                daemon=True)
                self._thread.start()
            if self._heap[0] is item:
                self._cond.notify()
        return item

    def _run(self) -> None:
        while True:
            with self._cond:
                while not self._heap or self._heap[0].due > time.monotonic():
                    timeout = self._heap[0].due - time.monotonic() if self._heap else None
                    self._cond.wait(timeout)
                item = heapq.heappop(self._heap)
            if not item.cancelled:
                try:
                    item.fn()
                except Exception:
                    log.exception("scheduled call failed")


SCHEDULER = Scheduler()


SWITCH_INTERVAL = 0.001


def tune_interpreter() -> None:
    """Component processes hand the GIL over after 1 ms instead of CPython's 5 ms.

    A thread that computes (the reasoner, a traceback being formatted) otherwise holds
    the GIL for up to 5 ms while a supervisor or an actor waits to restart or to reply.
    """
    import sys

    sys.setswitchinterval(SWITCH_INTERVAL)
