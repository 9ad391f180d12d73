"""mrss.logs in one process: records on a real bus, bounded, no loops, the shared file."""

from __future__ import annotations

import logging
import os
import re
import shutil
import signal
import subprocess
import sys
import tempfile
import textwrap
from collections.abc import Iterator
from pathlib import Path

import pytest

from mrss import logs
from mrss.bus import BusEndpoints, ProxyThread, Publisher, Subscriber
from mrss.errors import BusError
from mrss.messages import Envelope, LogRecord, Message
from mrss.testing import wait_until


@pytest.fixture()
def endpoints() -> Iterator[BusEndpoints]:
    """ipc endpoints in a short temp dir (unix socket paths are short); no proxy yet."""
    run_dir = Path(tempfile.mkdtemp(prefix="mrss-logs-"))
    try:
        yield BusEndpoints.ipc(run_dir)
    finally:
        shutil.rmtree(run_dir, ignore_errors=True)


class Bus:
    """A proxy, a publisher for the handler and a subscriber to `log.`, all real."""

    def __init__(self, endpoints: BusEndpoints) -> None:
        self.proxy = ProxyThread(endpoints).start()
        self.seen: list[Envelope] = []
        self.sub = Subscriber(endpoints, prefixes=["log."])
        self.sub.start(self.seen.append)
        assert self.sub.wait_connected(timeout=10)
        self.pub = Publisher(endpoints, src="logtest")
        assert self.pub.wait_connected(timeout=10)

    def records(self) -> list[LogRecord]:
        return [e.body for e in list(self.seen) if isinstance(e.body, LogRecord)]

    def close(self) -> None:
        self.pub.close()
        self.sub.close()
        self.proxy.stop()


@pytest.fixture()
def bus(endpoints: BusEndpoints) -> Iterator[Bus]:
    b = Bus(endpoints)
    try:
        yield b
    finally:
        b.close()


@pytest.fixture()
def attach() -> Iterator[list[logs.BusLogHandler]]:
    """Handlers put on the root logger by a test; always removed."""
    handlers: list[logs.BusLogHandler] = []
    root = logging.getLogger()
    level = root.level
    root.setLevel(logging.DEBUG)
    try:
        yield handlers
    finally:
        for handler in handlers:
            logs.remove_bus_handler(handler)
        root.setLevel(level)


def test_records_at_info_and_above_go_on_the_bus_as_log_records(
        bus: Bus, attach: list[logs.BusLogHandler]) -> None:
    attach.append(logs.install_bus_handler(logs.BusLogHandler("rcl", bus.pub.publish)))
    log = logging.getLogger("mrss.rcl")
    log.debug("not for the bus")
    log.info("robot %s is up", "ugv1")
    log.warning("link down")
    try:
        raise ValueError("bad goal")
    except ValueError:
        log.exception("goal refused")
    wait_until(lambda: len(bus.records()) >= 3, timeout=10, message="three records")
    got = bus.records()
    assert [(r.component, r.level) for r in got] == [
        ("rcl", "INFO"), ("rcl", "WARNING"), ("rcl", "ERROR")]
    assert got[0].message == "robot ugv1 is up"
    assert got[2].message.startswith("goal refused\nTraceback")
    assert "ValueError: bad goal" in got[2].message
    assert {e.topic for e in bus.seen} == {"log.rcl"}
    assert attach[0].dropped == 0


def test_bus_loggers_and_records_logged_while_publishing_never_loop(
        bus: Bus, attach: list[logs.BusLogHandler]) -> None:
    def publish_and_talk(msg: Message) -> object:
        # what a bus that logs about every message would do, on the handler's thread
        logging.getLogger("mrss.bus").warning("sent %s", msg.topic())
        logging.getLogger("mrss.rcl").warning("also said while publishing")
        return bus.pub.publish(msg)

    handler = logs.install_bus_handler(logs.BusLogHandler("rcl", publish_and_talk))
    attach.append(handler)
    logging.getLogger("mrss.bus").warning("the proxy is slow")
    logging.getLogger("mrss.bus.proxy").error("a child of the bus logger")
    for i in range(5):
        logging.getLogger("mrss.rcl").warning("user record %d", i)
    wait_until(lambda: len(bus.records()) >= 5, timeout=10, message="the user records")
    logs.remove_bus_handler(handler)  # flushes: nothing else may come after these five
    attach.clear()
    assert [r.message for r in bus.records()] == [f"user record {i}" for i in range(5)]
    assert handler.sent == 5 and handler.dropped == 0


def test_supervision_event_lines_are_not_published_twice(
        bus: Bus, attach: list[logs.BusLogHandler]) -> None:
    from mrss.supervision.events import SupEvents

    attach.append(logs.install_bus_handler(logs.BusLogHandler("root", bus.pub.publish)))
    SupEvents("root", bus.pub.publish).emit("start", "rcl", pid=42)  # logged and published
    logging.getLogger("mrss.supervise").info("after the event")
    wait_until(lambda: bus.records(), timeout=10, message="the plain record")
    assert [r.message for r in bus.records()] == ["after the event"]


def test_a_flood_is_bounded_and_the_drop_count_is_reported(
        bus: Bus, attach: list[logs.BusLogHandler], caplog: pytest.LogCaptureFixture) -> None:
    now = [1000.0]  # a frozen clock: the token bucket never refills during the flood
    handler = logs.BusLogHandler("flooder", bus.pub.publish, burst=400, rate=200.0,
                                 queue=1000, report_every=3600.0, clock=lambda: now[0])
    attach.append(logs.install_bus_handler(handler))
    log = logging.getLogger("mrss.flooder")
    for i in range(10_000):
        log.warning("flood line %d", i)  # returns at once whatever the bus does
    assert handler.dropped == 10_000 - 400
    logs.remove_bus_handler(handler)  # the last report goes out when the handler closes
    attach.clear()

    def flood_and_reports() -> tuple[int, int] | None:
        records = bus.records()
        lines = sum(1 for r in records if r.message.startswith("flood line"))
        reported = sum(int(m.group(1)) for r in records
                       if (m := re.match(r"dropped (\d+) log records", r.message)))
        return (lines, reported) if lines + reported == 10_000 else None

    counts = wait_until(flood_and_reports, timeout=15,
                        message="every flood line seen or reported dropped")
    assert counts == (400, 9_600)
    notices = [r for r in bus.records() if r.message.startswith("dropped")]
    assert all(r.level == "WARNING" and r.component == "flooder" for r in notices)
    # the same notices are logged (to the console and the log file), not only published
    logged = [r.getMessage() for r in caplog.records if r.name == "mrss.logs"]
    assert logged == [r.message for r in notices]


def test_the_bucket_refills_at_its_rate() -> None:
    now = [0.0]
    sent: list[Message] = []
    handler = logs.BusLogHandler("c", sent.append, rate=10.0, burst=5, clock=lambda: now[0])
    record = logging.LogRecord("mrss.c", logging.INFO, __file__, 1, "x", None, None)
    try:
        for _ in range(8):
            handler.emit(record)
        assert handler.dropped == 3
        now[0] += 0.5  # five more tokens
        for _ in range(6):
            handler.emit(record)
        assert handler.dropped == 4
    finally:
        handler.close()
    assert len([m for m in sent if isinstance(m, LogRecord) and m.message == "x"]) == 10


def test_logging_survives_the_bus_being_down_and_late(
        endpoints: BusEndpoints, attach: list[logs.BusLogHandler]) -> None:
    publisher = Publisher(endpoints, src="early")  # no proxy yet: nothing is listening
    try:
        handler = logs.install_bus_handler(logs.BusLogHandler("early", publisher.publish))
        attach.append(handler)
        for i in range(50):
            logging.getLogger("mrss.early").warning("before the bus %d", i)
        # handed over without an error: the publisher holds them until a proxy joins it
        wait_until(lambda: handler.sent == 50, timeout=10, message="records handed over")
        assert handler.dropped == 0
        # The proxy comes up; the held records go out when it joins the publisher, maybe
        # before this subscriber is there to see them: it sees the last ones, in order.
        bus = Bus(endpoints)
        try:
            logging.getLogger("mrss.early").warning("with the bus")
            wait_until(lambda: any(r.message == "with the bus" for r in bus.records()),
                       timeout=15, message="a record logged once the bus is up")
            before = [r.message for r in bus.records() if r.message.startswith("before")]
            assert before == [f"before the bus {i}" for i in range(50 - len(before), 50)]
        finally:
            bus.close()
    finally:
        publisher.close()


def test_a_closed_publisher_costs_records_not_the_component(
        caplog: pytest.LogCaptureFixture, attach: list[logs.BusLogHandler]) -> None:
    def closed(msg: Message) -> object:
        raise BusError("publisher is closed")

    handler = logs.install_bus_handler(logs.BusLogHandler("gone", closed))
    attach.append(handler)
    for i in range(20):
        logging.getLogger("mrss.gone").error("nobody hears %d", i)
    logs.remove_bus_handler(handler)
    attach.clear()
    assert handler.dropped == 20 and handler.sent == 0
    notices = [re.match(r"dropped (\d+)", r.getMessage()) for r in caplog.records
               if r.name == "mrss.logs"]
    assert sum(int(m.group(1)) for m in notices if m) == 20


def test_line_format_indents_continuation_lines() -> None:
    formatter = logs.LineFormatter("rcl")
    record = logging.LogRecord("mrss.rcl", logging.ERROR, __file__, 1, "two\nlines", None, None)
    line = formatter.format(record)
    assert re.fullmatch(r"\S+ \S+ rcl\[\d+\] ERROR two\n    lines", line)


WRITER = textwrap.dedent("""
    import logging, sys
    from mrss import logs
    logs.configure(sys.argv[1], console=False, file=sys.argv[2])
    for i in range(int(sys.argv[3])):
        logging.getLogger("mrss.w").info("%s %d %s", sys.argv[1], i, "x" * 6000)
""")


def test_processes_append_whole_lines_to_the_shared_log_file(tmp_path: Path) -> None:
    path = tmp_path / "mrss.log"
    writers = [subprocess.Popen([sys.executable, "-c", WRITER, f"w{n}", str(path), "300"])
               for n in range(3)]
    for w in writers:
        assert w.wait(timeout=60) == 0
    lines = path.read_text().splitlines()
    assert len(lines) == 900
    pattern = re.compile(r"\S+ \S+ (w\d)\[\d+\] INFO (w\d) (\d+) x{6000}")
    seen: dict[str, list[int]] = {}
    for line in lines:
        m = pattern.fullmatch(line)
        assert m and m.group(1) == m.group(2), line[:120]
        seen.setdefault(m.group(1), []).append(int(m.group(3)))
    assert seen == {f"w{n}": list(range(300)) for n in range(3)}


def test_stderr_that_is_the_log_file_gets_each_record_once(tmp_path: Path) -> None:
    path = tmp_path / "mrss.log"
    script = textwrap.dedent("""
        import logging, sys
        from mrss import logs
        logs.configure("c", file=sys.argv[1])
        logging.getLogger("mrss.c").warning("only once")
    """)
    fd = os.open(path, os.O_WRONLY | os.O_APPEND | os.O_CREAT)
    try:
        subprocess.run([sys.executable, "-c", script, str(path)], stderr=fd, check=True,
                       timeout=60)
    finally:
        os.close(fd)
    assert path.read_text().count("only once") == 1
    subprocess.run([sys.executable, "-c", script, str(path)], stderr=subprocess.DEVNULL,
                   check=True, timeout=60)
    assert path.read_text().count("only once") == 2


def test_a_forked_child_never_waits_on_nor_publishes_through_its_parents_handler(
        attach: list[logs.BusLogHandler]) -> None:
    r, w = os.pipe()
    handler = logs.install_bus_handler(
        logs.BusLogHandler("parent", lambda msg: os.write(w, b"p")))
    attach.append(handler)
    with handler._cond:  # another thread of the parent is inside the handler at the fork
        pid = os.fork()
        if pid == 0:  # the child: logging must neither block nor use the parent's bus
            try:
                logging.getLogger("mrss.child").warning("from the child")
                os.write(w, b"c" if handler.sent == 0 and handler.dropped == 0 else b"?")
            finally:
                os._exit(0)
    reaped = False

    def child_exited() -> bool:
        nonlocal reaped
        reaped = os.waitpid(pid, os.WNOHANG)[0] == pid
        return reaped

    try:
        wait_until(child_exited, timeout=10, message="the forked child logged and exited")
        assert os.read(r, 16) == b"c"
    finally:
        if not reaped:
            os.kill(pid, signal.SIGKILL)
            os.waitpid(pid, 0)
        os.close(r)
        os.close(w)


def test_the_console_handler_writes_to_the_stderr_of_the_moment_never_a_closed_one(
        monkeypatch: pytest.MonkeyPatch) -> None:
    """A process whose stderr was replaced and the old one closed (a test's captured
    output) keeps logging: no 'I/O operation on closed file' from a thread that logs
    later."""
    import io

    handler = logs.StderrHandler()
    handler.setFormatter(logging.Formatter("%(message)s"))
    first = io.StringIO()
    monkeypatch.setattr(sys, "stderr", first)
    handler.handle(logging.makeLogRecord({"msg": "one", "levelno": logging.WARNING}))
    assert first.getvalue() == "one\n"
    first.close()
    second = io.StringIO()
    monkeypatch.setattr(sys, "stderr", second)
    monkeypatch.setattr(logging, "raiseExceptions", True)  # a failure would be printed
    handler.handle(logging.makeLogRecord({"msg": "two", "levelno": logging.WARNING}))
    assert second.getvalue() == "two\n"
    # the one `logs.configure` gives the root logger is such a handler
    root = logging.getLogger()
    saved = root.handlers[:], root.level
    try:
        logs.configure("c", console=True)
        assert [type(h) for h in root.handlers] == [logs.StderrHandler]
    finally:
        for h in root.handlers[:]:
            root.removeHandler(h)
        for h in saved[0]:
            root.addHandler(h)
        root.setLevel(saved[1])
