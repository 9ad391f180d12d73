"""No message can silence a component (docs/bus.md, "Who may claim an incarnation"),
through real processes: `mrss supervise` runs a bus proxy, a talker (a tick every 0.1 s)
and a listener that repeats on the bus what it takes from the talker; the test forges
messages from a raw ZeroMQ socket and replays a recording with `mrss replay`. After
each, the listener has counted the refusal in its `Rejections` report (what the
dashboard shows) and still hears the live talker; a real restart of the talker is still
believed."""

from __future__ import annotations

import os
import re
import signal
import subprocess
import sys
import threading
from collections.abc import Iterator
from pathlib import Path

import pytest

from mrss.bus import BusEndpoints, Stale, Subscriber
from mrss.messages import Envelope, Heartbeat, LogRecord, Message, Rejections, SupEvent, encode
from mrss.recording.format import RecordedMessage, RecordingWriter
from mrss.testing import stop_supervised, wait_until
from tests.bus.bus_helpers import RawPublisher
from tests.commands.cli_bus import short_dir

ROOT = Path(__file__).resolve().parents[2]
HUGE = 10**9
PROJECT_TOML = """\
[project]
name = "door"

[supervisor]
strategy = "one_for_one"
intensity = 5
period = 10.0
heartbeat_interval = 0.5
heartbeat_misses = 600  # a loaded machine's stall is not a hang here

[supervisor.backoff]
initial = 0.02
jitter = 0.0

[components.bus]
kind = "bus"

[components.talker]
module = "tests.projects.workers:Talker"

[components.listener]
module = "tests.projects.workers:Listener"
hears = ["log.talker", "sup."]  # the talker's ticks; heartbeats, starts, ...
"""
HEARD = re.compile(r"heard (\S+) (-?\d+) tick (\S+)")


class System:
    """The supervised system, and what its listener says it took."""

    def __init__(self, root: Path) -> None:
        project = root / "door"
        project.mkdir()
        (project / "project.toml").write_text(PROJECT_TOML)
        self.run_dir = root / "run"
        self.run_dir.mkdir()
        self.endpoints = BusEndpoints.ipc(self.run_dir)
        self._lock = threading.Lock()
        self._seen: list[Envelope] = []
        self.sub = Subscriber(self.endpoints, prefixes=["log.listener", "edge.rejections"],
                              stale=Stale.KEEP)  # an observer, as the dashboard is
        self.sub.start(self._record)
        self._log = (root / "supervise.log").open("w")
        self.proc = subprocess.Popen(
            [sys.executable, "-m", "mrss", "supervise", "door", "--run-dir",
             str(self.run_dir), "--no-tui"], cwd=ROOT,
            env={**os.environ, "PYTHONPATH": str(ROOT), "MRSS_PROJECTS": str(root)},
            stdout=self._log, stderr=subprocess.STDOUT, start_new_session=True)

    def _record(self, env: Envelope) -> None:
        with self._lock:
            self._seen.append(env)

    def heard(self, inc: int | None = None) -> list[str]:
        """The ticks the listener took from the talker (of incarnation `inc`)."""
        with self._lock:
            records = [e.body.message for e in self._seen if isinstance(e.body, LogRecord)
                       and e.body.component == "listener"]
        found = [m for m in map(HEARD.fullmatch, records) if m and m[1] == "talker"]
        return [m[3] for m in found if inc is None or int(m[2]) == inc]

    def refused(self, kind: str) -> int:
        """How many refusals of `kind` the listener's last report counts."""
        with self._lock:
            reports = [e.body for e in self._seen if isinstance(e.body, Rejections)
                       and e.body.component == "listener"]
        return reports[-1].counts.get(kind, 0) if reports else 0

    def close(self) -> None:
        stop_supervised(self.proc)
        self.sub.close()
        self._log.close()


@pytest.fixture()
def system() -> Iterator[System]:
    with short_dir("mrss-door-") as root:
        running = System(root)
        try:
            wait_until(lambda: running.heard(1), 60, message="the listener hears the talker")
            yield running
        finally:
            running.close()


@pytest.fixture()
def forger(system: System) -> Iterator[RawPublisher]:
    """Raw ZeroMQ publishing on the system's bus: anything may say anything."""
    sock = RawPublisher(system.endpoints).wait_joined(30)
    try:
        yield sock
    finally:
        sock.close()


def tick(text: str) -> LogRecord:
    return LogRecord(component="talker", level="INFO", message=f"tick {text}")


def keeps_hearing_the_live_talker(system: System) -> None:
    """The listener takes the live talker's next ticks (it was not silenced)."""
    def live_ticks() -> int:  # of whichever incarnation is live (not forged ones)
        return sum(t.isdigit() for t in system.heard())

    before = live_ticks()
    wait_until(lambda: live_ticks() >= before + 5, 20,
               message="the listener still hears the live talker")


def forge(system: System, sock: RawPublisher, message: Message, *, src: str,
          inc: int) -> None:
    """Send `message` as (src, inc), then a marker tick of an unsupervised sender from the
    same socket (so after it, in order) until the listener has taken a marker: the forged
    message has been through the listener's door by then. (A raw socket's first messages
    are lost until the proxy has subscribed to it.)"""
    sent = iter(range(1, 1_000_000))

    def marker_taken() -> bool:
        sock.send_multipart(encode(message, src=src, inc=inc))
        sock.send_multipart(encode(tick(f"m{next(sent)}"), src="marker", inc=0))
        return any(m.startswith("m") for m in heard_from(system, "marker"))

    wait_until(marker_taken, 30, interval=0.2, message="the listener takes the marker")


def heard_from(system: System, src: str) -> list[str]:
    with system._lock:
        records = [e.body.message for e in system._seen if isinstance(e.body, LogRecord)]
    return [m[3] for m in map(HEARD.fullmatch, records) if m and m[1] == src]


def test_a_forged_heartbeat_with_a_huge_incarnation_silences_nobody(
        system: System, forger: RawPublisher) -> None:
    forge(system, forger, Heartbeat(component="talker", pid=1), src="talker", inc=HUGE)
    keeps_hearing_the_live_talker(system)
    forge(system, forger, tick("forged"), src="talker", inc=HUGE)
    assert "forged" not in system.heard()
    kind = "bus message from talker: an incarnation its supervisor did not start"
    wait_until(lambda: system.refused(kind) >= 2, 30, message="refusals in the report")


def test_a_sup_start_not_sent_by_the_supervisor_silences_nobody(
        system: System, forger: RawPublisher) -> None:
    forged = SupEvent(event="start", child="talker", supervisor="door", pid=1,
                      detail={"inc": HUGE})
    forge(system, forger, forged, src="supervisor", inc=0)
    keeps_hearing_the_live_talker(system)
    kind = "bus message from supervisor: an incarnation its supervisor did not start"
    wait_until(lambda: system.refused(kind) >= 1, 30, message="the refusal in the report")


def test_a_replayed_recording_with_a_higher_incarnation_silences_nobody(
        system: System, tmp_path: Path) -> None:
    recording = tmp_path / "restarted.mrssrec"
    with recording.open("wb") as out:  # another run, where the talker had restarted
        writer = RecordingWriter(out, created=0.0)
        for n in range(3):
            writer.write(RecordedMessage(float(n), encode(tick(f"replayed-{n}"),
                                                          src="talker", inc=2)))
    kind = "bus message from talker: replayed, not live"

    def replayed() -> bool:  # refused, or (the bug) taken
        done = subprocess.run(
            [sys.executable, "-m", "mrss", "replay", str(recording), "--run-dir",
             str(system.run_dir), "--as-fast-as-possible"], cwd=ROOT, capture_output=True,
            text=True, timeout=60)
        assert done.returncode == 0, done.stderr
        return system.refused(kind) > 0 or any(t.startswith("replayed")
                                               for t in system.heard())

    wait_until(replayed, 60, interval=0.5, message="the replay through the listener's door")
    assert not [t for t in system.heard() if t.startswith("replayed")]
    keeps_hearing_the_live_talker(system)


def test_a_real_restart_of_the_talker_is_still_believed(system: System) -> None:
    pid = int((system.run_dir / "talker.1.started").read_text())
    os.kill(pid, signal.SIGKILL)  # the root restarts it as incarnation 2
    wait_until(lambda: len(system.heard(2)) >= 3, 30,
               message="the listener hears the restarted talker")
