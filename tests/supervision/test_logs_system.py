"""`mrss supervise` with logging: every record on stderr and in mrss.log, INFO+ on the bus.

Runs tests/supervision/projects/logsdemo as a real process tree: the bus proxy, `chatty`
(a warning every 0.2 s, and one on the `mrss.bus` logger) and `flooder` (10,000
warnings as fast as it can once the test says so).
"""

from __future__ import annotations

import os
import re
import signal
import subprocess
import sys
from collections.abc import Iterator
from dataclasses import dataclass, field
from pathlib import Path

import psutil
import pytest

from mrss.bus import BusEndpoints, Subscriber
from mrss.messages import Envelope, LogRecord
from mrss.testing import wait_until

PROJECTS = Path(__file__).resolve().parent / "projects"
FLOOD = 10_000


@dataclass
class System:
    proc: subprocess.Popen[bytes]
    run_dir: Path
    stderr: Path
    seen: list[Envelope] = field(default_factory=list)

    @property
    def log(self) -> str:
        return (self.run_dir / "mrss.log").read_text()

    def records(self, component: str | None = None) -> list[LogRecord]:
        return [e.body for e in list(self.seen) if isinstance(e.body, LogRecord)
                and (component is None or e.body.component == component)]

    def stop(self) -> int:
        self.proc.send_signal(signal.SIGTERM)
        return self.proc.wait(timeout=30)


@pytest.fixture()
def system(tmp_path: Path) -> Iterator[System]:
    stderr = tmp_path / "stderr.txt"
    sub = Subscriber(BusEndpoints.ipc(tmp_path), prefixes=["log."])
    with stderr.open("wb") as err:
        proc = subprocess.Popen(
            [sys.executable, "-m", "mrss", "supervise", "logsdemo", "--run-dir", str(tmp_path)],
            env={**os.environ, "MRSS_PROJECTS": str(PROJECTS)}, stdin=subprocess.DEVNULL,
            stdout=subprocess.DEVNULL, stderr=err)
    running = System(proc, tmp_path, stderr)
    sub.start(running.seen.append)
    try:
        wait_until(lambda: sub.wait_connected(timeout=0.5), timeout=30,
                   message="the bus proxy up")
        yield running
    finally:
        sub.close()
        if proc.poll() is None:
            for child in psutil.Process(proc.pid).children(recursive=True):
                child.kill()
            proc.kill()
        proc.wait(timeout=10)


def _file_line(record: LogRecord) -> re.Pattern[str]:
    first, *rest = record.message.split("\n")
    text = "\n    ".join([first, *rest])
    return re.compile(rf"^\S+ \S+ {re.escape(record.component)}\[\d+\] {record.level} "
                      rf"{re.escape(text)}$", re.M)


@pytest.mark.slow
def test_a_components_warning_is_on_the_bus_and_in_the_log_file(system: System) -> None:
    def third_hello() -> LogRecord | None:
        return next((r for r in system.records("chatty")
                     if r.message == "chatty says hello 3"), None)

    hello = wait_until(third_hello, timeout=30, message="chatty's third hello on log.chatty")
    assert hello is not None and hello.level == "WARNING"
    wait_until(lambda: "chatty says hello 3" in system.log, timeout=10)
    assert _file_line(hello).search(system.log)
    # the bus's own logger: in the file, never on the bus
    assert "chatty via the bus logger 3" in system.log
    assert not [r for r in system.records() if "via the bus logger" in r.message]
    assert system.stop() == 0
    # the root's records go on the bus too (the proxy is the last to stop)
    assert any(r.message == "logsdemo: stopping every child in reverse order"
               for r in system.records("logsdemo"))
    log = system.log
    # what the dashboard got is what the file has, record for record
    for record in system.records():
        assert _file_line(record).search(log), record
    # and the file holds exactly the lines stderr showed, from every process
    assert sorted(log.splitlines()) == sorted(system.stderr.read_text().splitlines())
    for who, level in (("logsdemo", "INFO"), ("bus", "INFO"), ("chatty", "WARNING")):
        assert re.search(rf"^\S+ \S+ {who}\[\d+\] {level} ", log, re.M), who


@pytest.mark.slow
def test_a_flood_of_log_lines_does_not_stall_the_component_and_drops_are_reported(
        system: System) -> None:
    wait_until(lambda: system.records("chatty"), timeout=30, message="the bus carries logs")
    (system.run_dir / "flood.go").write_text("go")
    done = system.run_dir / "flooder.flooded"
    wait_until(done.exists, timeout=60, message="the flood was logged to the end")

    def lines_and_reported() -> tuple[int, int] | None:
        records = system.records("flooder")
        lines = sum(1 for r in records if r.message.startswith("flood line "))
        reported = sum(int(m.group(1)) for r in records
                       if (m := re.match(r"dropped (\d+) log records", r.message)))
        return (lines, reported) if lines + reported == FLOOD else None

    counts = wait_until(lines_and_reported, timeout=20,
                        message="every flood line on the bus or reported dropped")
    assert counts is not None
    lines, reported = counts
    assert reported > 0 and lines < FLOOD / 2  # bounded: most of the flood is dropped
    log = system.log
    assert len(re.findall(r"flooder\[\d+\] WARNING flood line \d+$", log, re.M)) == FLOOD
    in_file = sum(int(n) for n in re.findall(
        r"flooder\[\d+\] WARNING dropped (\d+) log records", log))
    assert in_file == reported
    assert system.stop() == 0
    log = system.log
    # it kept its heartbeats through the flood: never restarted, never seen hung
    assert not re.search(r"(exit|hang) flooder .*(killed|crashed|hung)", log)
    assert "start flooder pid" in log and "inc=2" not in log
