"""Log records of every process: one line format, the run's log file, and the bus.

Every MRSS process logs through `logging`. `configure` gives the root logger the
handlers of one process, all with the same `LineFormatter` line:

    2025-01-31 12:00:00,123 rcl[4242] WARNING ugv1: link down

- the console (stderr), unless asked not to;
- the run's log file `<run_dir>/mrss.log` (`AppendFileHandler`): every process of a run
  appends to it directly (O_APPEND, one `write` per record, so lines of different
  processes never mix), and rotates it by size (`mrss.logfile`: `[logs] max_mb`,
  `keep`, handed down in `$MRSS_LOG_ROTATION`). When stderr already goes to that file
  (it *is* the file, or `$MRSS_STDERR_LOG` names it: the dashboard mode pipes the
  system's stderr into it) the file handler writes each record, once, and not the console.

`BusLogHandler` puts each record at INFO and above on the bus as a
`mrss.messages.LogRecord(component, level, message)` on `log.<component>`, for the
dashboard. Logging never waits for the bus: `emit` only queues (a bounded queue behind a
token bucket); a thread of the handler publishes. What it cannot take is dropped and
counted, and the count is reported (logged, and published when the bus takes it).
Records of the bus's own loggers (`mrss.bus`), of this module, and any record logged on
the handler's own thread while it publishes are never published, so a bus that logs
cannot loop. Supervision events (logged by `SupEvents.emit`) are already on the bus as
`sup.*`, and `mrss.runtime.remote` publishes its own `LogRecord`s: neither is
published twice.
"""

from __future__ import annotations

import logging
import os
import sys
import threading
import time
import weakref
from collections import deque
from collections.abc import Callable, Iterable
from pathlib import Path
from typing import Any

from mrss.logfile import LogFile, Rotation
from mrss.messages import LogRecord, Message

LOG_FILE = "mrss.log"
STDERR_LOG_ENV = "MRSS_STDERR_LOG"  # the log file this process's stderr is piped into
LINE_FORMAT = "%(asctime)s {component}[%(process)d] %(levelname)s %(message)s"
# Loggers (and their children) whose records never go on the bus.
NOT_PUBLISHED = ("mrss.bus", "mrss.logs", "mrss.runtime.remote")
RATE = 200.0  # records per second a process may put on the bus, sustained
BURST = 400  # ... and in one burst
QUEUE = 1000  # records waiting for the publishing thread
REPORT_EVERY = 2.0  # seconds between two reports of dropped records

Publish = Callable[[Message], object]
log = logging.getLogger("mrss.logs")


def log_file(run_dir: str | os.PathLike[str]) -> Path:
    """The log file of a run: `<run_dir>/mrss.log`."""
    return Path(run_dir) / LOG_FILE


class LineFormatter(logging.Formatter):
    """`time component[pid] LEVEL message`; continuation lines (tracebacks) are indented."""

    def __init__(self, component: str) -> None:
        super().__init__(LINE_FORMAT.format(component=component.replace("%", "%%")))

    def format(self, record: logging.LogRecord) -> str:
        return super().format(record).replace("\n", "\n    ")


class AppendFileHandler(logging.Handler):
    """Appends each record to a file shared by many processes, in one `write` call,
    rotating it by `rotation` (`mrss.logfile.LogFile`; default: `$MRSS_LOG_ROTATION`)."""

    def __init__(self, path: str | os.PathLike[str], rotation: Rotation | None = None) -> None:
        super().__init__()
        self.path = Path(path)
        self.file = LogFile(self.path, rotation or Rotation.from_env())

    def emit(self, record: logging.LogRecord) -> None:
        try:
            self.file.write((self.format(record) + "\n").encode("utf-8", "replace"))
        except Exception:
            self.handleError(record)

    def close(self) -> None:
        self.acquire()
        try:
            self.file.close()
        finally:
            self.release()
        super().close()


def stderr_is(path: str | os.PathLike[str]) -> bool:
    """Whether file descriptor 2 goes to the log file at `path`: it is that file, or
    `$MRSS_STDERR_LOG` names it (a pipe the dashboard's process writes into it)."""
    piped = os.environ.get(STDERR_LOG_ENV)
    if piped and Path(piped).resolve() == Path(path).resolve():
        return True
    try:
        return os.path.samestat(os.fstat(2), os.stat(path))
    except (OSError, ValueError):
        return False


class StderrHandler(logging.StreamHandler):  # type: ignore[type-arg]
    """A console handler that writes to whatever `sys.stderr` is when a record comes,
    not the stream it was made with (as `logging.lastResort` does): a process whose
    stderr is replaced and closed later (a test's captured output) never has a thread
    log into a closed file ("I/O operation on closed file")."""

    def __init__(self) -> None:
        super().__init__(sys.stderr)

    @property
    def stream(self) -> Any:
        return sys.stderr

    @stream.setter
    def stream(self, value: Any) -> None:
        del value  # always the current sys.stderr


def configure(component: str, *, level: int = logging.INFO, console: bool = True,
              file: str | os.PathLike[str] | None = None) -> None:
    """Give this process's root logger its console and file handlers (replacing others).

    When stderr already goes to that file, the file handler writes each record (it
    rotates the file) and the console handler is left out.
    """
    root = logging.getLogger()
    for handler in root.handlers[:]:
        root.removeHandler(handler)
        handler.close()  # a StreamHandler leaves its stream open
    root.setLevel(level)
    formatter = LineFormatter(component)
    appender, problem = None, None
    if file is not None:
        try:
            appender = AppendFileHandler(file)
        except OSError as exc:
            problem = exc
        else:
            appender.setFormatter(formatter)
            root.addHandler(appender)
    if console and not (appender is not None and stderr_is(appender.path)):
        stream = StderrHandler()
        stream.setFormatter(formatter)
        root.addHandler(stream)
    if problem is not None:
        log.warning("cannot write the log file %s: %s", file, problem)


def is_sup_event(record: logging.LogRecord) -> bool:
    """Whether `record` is the log line of a supervision event (already on the bus)."""
    return record.funcName == "emit" and record.module == "events" \
        and record.name.startswith("mrss.supervision.")


class BusLogHandler(logging.Handler):
    """Publishes records as `LogRecord`s on `log.<component>`; see the module docstring.

    `publish` is called on the handler's own thread only (so a `ComponentContext` may make
    its publisher on first use there). `dropped` counts the records the bus did not get
    (over the rate, queue full, or publishing raised); `sent` those it did.
    """

    def __init__(
        self, component: str, publish: Publish, *, level: int = logging.INFO,
        rate: float = RATE, burst: int = BURST, queue: int = QUEUE,
        report_every: float = REPORT_EVERY, exclude: Iterable[str] = NOT_PUBLISHED,
        clock: Callable[[], float] = time.monotonic,
    ) -> None:
        super().__init__(level)
        self.component = component
        self.rate = rate
        self.burst = burst
        self.report_every = report_every
        self.sent = 0
        self.dropped = 0
        self._publish = publish
        self._exclude = tuple(exclude)
        self._clock = clock
        self._queue: deque[LogRecord] = deque()
        self._limit = queue
        self._cond = threading.Condition(threading.Lock())
        self._tokens = float(burst)
        self._refilled = clock()
        self._reported = 0
        self._last_report = float("-inf")
        self._closing = False
        self._thread: threading.Thread | None = None
        self._inert = False
        self.setFormatter(logging.Formatter("%(message)s"))
        handler = weakref.ref(self)
        os.register_at_fork(after_in_child=lambda: _go_inert(handler()))

    # -- any thread ---------------------------------------------------------------------
    def emit(self, record: logging.LogRecord) -> None:
        if self._inert or self._excluded(record):
            return
        try:
            message = self.format(record)
        except Exception:
            self.handleError(record)
            return
        item = LogRecord(component=self.component, level=record.levelname, message=message)
        with self._cond:
            if self._closing and self._thread is None:
                self.dropped += 1
                return
            now = self._clock()
            self._tokens = min(float(self.burst),
                               self._tokens + (now - self._refilled) * self.rate)
            self._refilled = now
            if self._tokens < 1.0 or len(self._queue) >= self._limit:
                self.dropped += 1
                self._cond.notify()
                return
            self._tokens -= 1.0
            self._queue.append(item)
            if self._thread is None:
                self._thread = threading.Thread(target=self._run, daemon=True,
                                                name=f"mrss-log-bus-{self.component}")
                self._thread.start()
            elif len(self._queue) == 1:
                self._cond.notify()

    def _excluded(self, record: logging.LogRecord) -> bool:
        name = record.name
        if any(name == p or name.startswith(p + ".") for p in self._exclude):
            return True
        if threading.current_thread() is self._thread:
            return True  # logged while publishing: publishing it again could loop
        return is_sup_event(record)

    def close(self, timeout: float = 1.0) -> None:
        """Publish what is queued (and the drop count) for up to `timeout` s, then stop."""
        with self._cond:
            self._closing = True
            thread = self._thread
            self._cond.notify()
        if thread is not None and thread is not threading.current_thread():
            thread.join(timeout)
        super().close()

    # -- the handler's thread -------------------------------------------------------------
    def _run(self) -> None:
        while True:
            with self._cond:
                while not self._queue and not self._closing and not self._report_due():
                    self._cond.wait(self._until_report())
                batch = list(self._queue)
                self._queue.clear()
                closing = self._closing
            for item in batch:
                self._send(item)
            self._report(force=closing)
            if closing:
                with self._cond:
                    if not self._queue:
                        self._thread = None
                        return

    def _send(self, item: LogRecord) -> bool:
        try:
            self._publish(item)
        except Exception:  # the bus is down or closed: the log file still has the record
            with self._cond:
                self.dropped += 1
            return False
        self.sent += 1
        return True

    def _report_due(self) -> bool:
        return self.dropped > self._reported and \
            self._clock() - self._last_report >= self.report_every

    def _until_report(self) -> float | None:
        if self.dropped <= self._reported:
            return None
        return max(0.0, self._last_report + self.report_every - self._clock())

    def _report(self, *, force: bool = False) -> None:
        with self._cond:
            if not (self._report_due() or (force and self.dropped > self._reported)):
                return
            count = self.dropped - self._reported
            self._reported = self.dropped
            self._last_report = self._clock()
        text = drop_notice(count, self.rate)
        log.warning("%s", text)  # the log file and console have it even if the bus does not
        item = LogRecord(component=self.component, level="WARNING", message=text)
        try:
            self._publish(item)
        except Exception:
            return
        self.sent += 1


def _go_inert(handler: BusLogHandler | None) -> None:
    """In a process forked from one with `handler`: its thread and the parent's bus
    socket are not ours, so it publishes nothing (the child has its own stderr/file)."""
    if handler is not None:
        handler._inert = True
        handler._cond = threading.Condition(threading.Lock())
        handler._queue.clear()
        handler._thread = None


def drop_notice(count: int, rate: float) -> str:
    """The text reporting `count` records the bus did not get."""
    return (f"dropped {count} log records from the bus (more than {rate:g} a second, or the "
            f"bus was slow or down); the log file has every record")


def install_bus_handler(handler: BusLogHandler) -> BusLogHandler:
    """Attach `handler` to the root logger; returns it (for `remove_bus_handler`)."""
    logging.getLogger().addHandler(handler)
    return handler


def remove_bus_handler(handler: BusLogHandler, timeout: float = 1.0) -> None:
    """Detach `handler` and publish what it still holds, for up to `timeout` seconds."""
    logging.getLogger().removeHandler(handler)
    handler.close(timeout)
