"""Robot data handed to one thread of its own, in order (the data layer's telemetry)."""

from __future__ import annotations

import logging
import threading
from collections import deque
from collections.abc import Callable

from mrss.messages import RobotData

log = logging.getLogger("mrss.datalayer")


class TelemetryQueue:
    """Robot data handed to one thread of its own, in order, so the subscriber's thread
    never waits for the project's `on_telemetry`. Cheaper per record than an executor: no
    Future per record, and the thread is woken only when it waits (it then takes what
    came meanwhile). `close` drops what is queued; a record being handled finishes."""

    def __init__(self, handle: Callable[[RobotData], object]) -> None:
        self._handle = handle
        self._queue: deque[RobotData] = deque()
        self._wake = threading.Condition(threading.Lock())
        self._idle = False   # the thread waits (or is about to) for a record
        self._closed = False
        self._thread = threading.Thread(target=self._run, name="dl-telemetry", daemon=True)
        self._thread.start()

    def put(self, data: RobotData) -> None:
        self._queue.append(data)
        if self._idle:  # set before the thread last looked at the queue: it may sleep
            with self._wake:
                self._wake.notify()

    def pending(self) -> int:
        """Records queued and not yet taken."""
        return len(self._queue)

    def _run(self) -> None:
        queue = self._queue
        while True:
            while queue and not self._closed:
                data = queue.popleft()
                try:
                    self._handle(data)
                except Exception:
                    log.exception("telemetry of robot %s was not handled", data.robot)
            with self._wake:
                self._idle = True
                if not queue and not self._closed:
                    self._wake.wait()
                self._idle = False
                if self._closed:
                    return

    def close(self) -> None:
        with self._wake:
            self._closed = True
            self._queue.clear()
            self._wake.notify()
