"""One thread for every link of a process: a heap of deadlines and a selector of sockets.

A link that must act without incoming data (send its controller heartbeat, notice that
telemetry stopped) schedules a job here instead of running a thread of its own, and a
link that reads a socket (MAVLink over UDP) registers it as a reader: with 100 links,
one thread waits for the earliest deadline or the next datagram instead of 100 threads
polling, which on a busy machine also means the GIL is handed to the action path
sooner (fewer threads compete for it when telemetry arrives in bursts).

A job is a function returning the seconds until it wants to run again, or None when it
is done; a reader's callback runs when its socket is readable. Both run one at a time on
the loop thread, so a link's reader and its jobs never run concurrently: they must
return quickly (no waiting on a robot). A job that raises is logged and runs again a
second later, so a bug cannot silence a link's watchdog for good; a reader that raises
is logged and stays registered. The thread starts with the first job or reader and
ends when the last is gone (it is a daemon thread).

The supervisor's own delayed calls have their scheduler (mrss.supervision.threads):
a link's callbacks cannot hold up a restart, nor a restart a link's heartbeat.
"""

from __future__ import annotations

import heapq
import itertools
import logging
import selectors
import socket
import threading
import time
from collections.abc import Callable
from typing import Any

Job = Callable[[], "float | None"]
Reader = Callable[[], None]

RETRY_AFTER_ERROR_S = 1.0
THREAD_NAME = "mrss-link-loop"
REMOVE_TIMEOUT_S = 5.0


class TimerHandle:
    """One scheduled job; `cancel()` stops it (a run under way finishes)."""

    __slots__ = ("_owner", "cancelled", "job", "name")

    def __init__(self, owner: Timers, job: Job, name: str) -> None:
        self._owner = owner
        self.job = job
        self.name = name
        self.cancelled = False

    def cancel(self) -> None:
        """Run the job no more; the loop drops it."""
        self.cancelled = True
        self._owner.wake()


class Timers:
    """Deadlines and readable sockets served by one thread, started and ended on demand."""

    def __init__(self, name: str = THREAD_NAME) -> None:
        self.name = name
        self.log = logging.getLogger("mrss.links.timers")
        self._lock = threading.Lock()
        self._heap: list[tuple[float, int, TimerHandle]] = []
        self._seq = itertools.count()
        self._thread: threading.Thread | None = None
        self._selector: selectors.BaseSelector | None = None
        self._wake_r: socket.socket | None = None
        self._wake_w: socket.socket | None = None
        self._woken = False
        self._readers: dict[int, tuple[Any, Reader, str]] = {}  # fd -> (file, callback, name)
        self._changes: list[tuple[int, Any, Reader | None, str, threading.Event]] = []

    # -- what links use ------------------------------------------------------------------
    def schedule(self, job: Job, delay: float = 0.0, name: str = "job") -> TimerHandle:
        """Run `job` after `delay` seconds, then again after each delay it returns."""
        handle = TimerHandle(self, job, name)
        with self._lock:
            heapq.heappush(self._heap, (time.monotonic() + max(delay, 0.0),
                                        next(self._seq), handle))
            first = self._heap[0][2] is handle
            started = self._ensure_thread()
        if first and not started:
            self.wake()
        return handle

    def add_reader(self, fileobj: Any, callback: Reader, name: str = "reader") -> None:
        """Call `callback()` on the loop thread whenever `fileobj` is readable."""
        self._change(fileobj.fileno(), fileobj, callback, name)

    def remove_reader(self, fileobj: Any) -> None:
        """Stop watching `fileobj`; once this returns its callback is not running and
        never runs again (called from the loop thread itself, at once)."""
        self._change(fileobj.fileno(), fileobj, None, "")

    def wake(self) -> None:
        """Make the loop look at its heap and readers now."""
        with self._lock:
            if self._wake_w is None or self._woken:
                return
            self._woken = True
            wake = self._wake_w
        try:
            wake.send(b"\0")
        except OSError:
            pass  # the loop is ending; a new one starts with the next job

    @property
    def jobs(self) -> int:
        """Scheduled jobs not cancelled or done."""
        with self._lock:
            return sum(1 for _, _, h in self._heap if not h.cancelled)

    @property
    def running(self) -> bool:
        """Whether the loop thread runs."""
        with self._lock:
            return self._thread is not None

    # -- the loop --------------------------------------------------------------------------
    def _change(self, fd: int, fileobj: Any, callback: Reader | None, name: str) -> None:
        done = threading.Event()
        with self._lock:
            if threading.current_thread() is self._thread:
                self._apply(fd, fileobj, callback, name)
                return
            self._changes.append((fd, fileobj, callback, name, done))
            started = self._ensure_thread()
        if not started:
            self.wake()
        if not done.wait(REMOVE_TIMEOUT_S):
            self.log.error("the link loop did not take a reader change within %.0f s "
                           "(a callback blocks it?)", REMOVE_TIMEOUT_S)

    def _apply(self, fd: int, fileobj: Any, callback: Reader | None, name: str) -> None:
        # Caller holds the lock, on the loop thread.
        assert self._selector is not None
        if fd in self._readers:
            self._selector.unregister(fd)
            del self._readers[fd]
        if callback is not None:
            self._selector.register(fd, selectors.EVENT_READ)
            self._readers[fd] = (fileobj, callback, name)

    def _ensure_thread(self) -> bool:
        """Start the loop if it is not running (caller holds the lock); True if started."""
        if self._thread is not None:
            return False
        self._selector = selectors.DefaultSelector()
        self._wake_r, self._wake_w = socket.socketpair()
        self._wake_r.setblocking(False)
        self._selector.register(self._wake_r.fileno(), selectors.EVENT_READ)
        self._woken = False
        self._thread = threading.Thread(target=self._run, name=self.name, daemon=True)
        self._thread.start()
        return True

    def _run(self) -> None:
        with self._lock:
            selector, wake_r = self._selector, self._wake_r
        assert selector is not None and wake_r is not None
        try:
            while self._turn(selector, wake_r):
                pass
        finally:
            selector.close()
            wake_r.close()

    def _turn(self, selector: selectors.BaseSelector, wake_r: socket.socket) -> bool:
        """One round: take changes, wait, serve readers, run due jobs; False to end."""
        with self._lock:
            for fd, fileobj, callback, name, done in self._changes:
                self._apply(fd, fileobj, callback, name)
                done.set()
            self._changes.clear()
            while self._heap and self._heap[0][2].cancelled:
                heapq.heappop(self._heap)
            if not self._heap and not self._readers:
                self._thread = self._selector = self._wake_r = None
                if self._wake_w is not None:
                    self._wake_w.close()
                    self._wake_w = None
                return False
            timeout = max(self._heap[0][0] - time.monotonic(), 0.0) if self._heap else None
        ready = selector.select(timeout)
        for key, _ in ready:
            if key.fd == wake_r.fileno():
                self._drain_wake(wake_r)
                continue
            reader = self._readers.get(key.fd)
            if reader is not None:
                self._read(reader)
        self._run_due()
        return True

    def _drain_wake(self, wake_r: socket.socket) -> None:
        with self._lock:
            self._woken = False
        try:
            while wake_r.recv(4096):
                pass
        except OSError:
            pass  # nothing more to read

    def _read(self, reader: tuple[Any, Reader, str]) -> None:
        try:
            reader[1]()
        except Exception:
            self.log.exception("link reader %s failed; it stays registered", reader[2])

    def _run_due(self) -> None:
        now = time.monotonic()
        while True:
            with self._lock:
                if not self._heap or self._heap[0][0] > now:
                    return
                _, _, handle = heapq.heappop(self._heap)
            again = self._call(handle)
            if again is not None and not handle.cancelled:
                with self._lock:
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


#: The process's shared link loop.
TIMERS = Timers()
