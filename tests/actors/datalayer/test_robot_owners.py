"""Robot data is taken only from the component that owns the robot's link
(mrss/edge/robot_owners.py), through real processes: `mrss supervise` runs a bus proxy,
a `links` component whose table lists robot uav1, and the data layer, whose project
DataLayer turns every record it takes into a percept `telemetry(uav1, Note)`. Robot data
from a tool, from `links` without its incarnation's credential, and a replay of the
owner's are refused and counted in the data layer's report; the owner's own is taken."""

from __future__ import annotations

import os
import subprocess
import sys
import threading
from collections.abc import Iterator
from pathlib import Path

import pytest

from mrss.bus import BusEndpoints, Publisher, Stale, Subscriber
from mrss.messages import Envelope, Percept, Rejections, RobotData, encode
from mrss.recording.format import RecordedMessage, RecordingWriter
from mrss.testing import stop_supervised, wait_until
from tests.commands.cli_bus import short_dir

ROOT = Path(__file__).resolve().parents[3]
PROJECT_TOML = """\
[project]
name = "owners"

[supervisor]
heartbeat_interval = 0.5
heartbeat_misses = 600  # a loaded machine's stall is not a hang here

[components.bus]
kind = "bus"

[components.links]                  # owns uav1's link (a worker that does nothing)
module = "tests.projects.workers:Worker"

[components.links.robots.uav1]
link = "mavlink"

[components.datalayer]
kind = "datalayer"
world_model = "none"
"""
DATALAYER = '''\
from mrss.api import DataLayer


class Echo(DataLayer):
    """Says which robot data it took, as a percept."""

    def on_telemetry(self, robot, data):
        self.context.percept("telemetry", robot, str(data.get("note", "")))
'''


class System:
    """The supervised system, and what the data layer took and refused."""

    def __init__(self, root: Path) -> None:
        project = root / "owners"
        project.mkdir()
        (project / "project.toml").write_text(PROJECT_TOML)
        (project / "datalayer.py").write_text(DATALAYER)
        self.run_dir = root / "run"
        self.run_dir.mkdir()
        self.endpoints = BusEndpoints.ipc(self.run_dir)
        self.owner: Publisher | None = None
        self._lock = threading.Lock()
        self._seen: list[Envelope] = []
        self.sub = Subscriber(self.endpoints, prefixes=["percept", "edge.rejections"],
                              stale=Stale.KEEP)
        self.sub.start(self._record)
        self._log = (root / "supervise.log").open("w")
        self.proc = subprocess.Popen(
            [sys.executable, "-m", "mrss", "supervise", "owners", "--run-dir",
             str(self.run_dir), "--no-tui"], cwd=ROOT,
            env={**os.environ, "PYTHONPATH": str(ROOT), "MRSS_PROJECTS": str(root)},
            stdout=self._log, stderr=subprocess.STDOUT, start_new_session=True)

    def _record(self, env: Envelope) -> None:
        with self._lock:
            self._seen.append(env)

    def taken(self) -> list[str]:
        """The notes of the robot data the data layer took (`telemetry(Robot, Note)`)."""
        with self._lock:
            literals = [e.body.literal for e in self._seen if isinstance(e.body, Percept)]
        return [lit.rpartition(",")[2].strip('")') for lit in literals
                if lit.startswith("telemetry(")]

    def refused(self, kind: str) -> int:
        with self._lock:
            reports = [e.body for e in self._seen if isinstance(e.body, Rejections)
                       and e.body.component == "datalayer"]
        return reports[-1].counts.get(kind, 0) if reports else 0

    def close(self) -> None:
        stop_supervised(self.proc)
        self.sub.close()
        self._log.close()


@pytest.fixture()
def system() -> Iterator[System]:
    with short_dir("mrss-owners-") as root:
        running = System(root)
        try:
            wait_until(lambda: (running.run_dir / "links.1.started").exists(), 60,
                       message="the system started")
            # The owner's own publisher: the test holds the run's key, as `links` does.
            key = running.run_dir / "incarnation.key"
            owner = running.endpoints.keyed(key) if key.exists() else running.endpoints
            running.owner = Publisher(owner, src="links", inc=1)
            yield running
        finally:
            if running.owner is not None:
                running.owner.close()
            running.close()


def record(note: str) -> RobotData:
    return RobotData(robot="uav1", data={"battery": 50, "note": note})


def test_robot_data_is_taken_only_from_the_owner_of_its_link(
        system: System, tmp_path: Path) -> None:
    owner = system.owner
    assert owner is not None
    wait_until(lambda: owner.publish(record("owner")) and "owner" in system.taken(), 60,
               interval=0.2, message="the owner's robot data taken")
    with Publisher(system.endpoints, src="tool") as tool, \
            Publisher(system.endpoints, src="links") as unproven:
        tool.wait_connected(10)
        unproven.wait_connected(10)
        kinds = ["robot data from tool: not from links, the owner of its link",
                 "robot data from links: links without a proven incarnation"]

        def both_refused() -> bool:
            tool.publish(record("tool"))
            unproven.publish(record("unproven"))
            return all(system.refused(kind) > 0 for kind in kinds)

        wait_until(both_refused, 30, interval=0.2, message="both refusals reported")
    recording = tmp_path / "owner.mrssrec"
    with recording.open("wb") as out:  # the owner's own data, from a recording
        proof: bytes = getattr(owner, "cred", b"")  # its credential, as recorded
        frames = encode(record("replayed"), src="links", inc=1, cred=proof) if proof \
            else encode(record("replayed"), src="links", inc=1)
        RecordingWriter(out, created=0.0).write(RecordedMessage(0.0, frames))
    kind = "bus message from links: replayed, not live"

    def replayed() -> bool:
        done = subprocess.run(
            [sys.executable, "-m", "mrss", "replay", str(recording), "--run-dir",
             str(system.run_dir)], cwd=ROOT, capture_output=True, text=True, timeout=60)
        assert done.returncode == 0, done.stderr
        return system.refused(kind) > 0

    wait_until(replayed, 60, interval=0.5, message="the replay refused")
    owner.publish(record("owner-again"))
    wait_until(lambda: "owner-again" in system.taken(), 20,
               message="the owner's robot data still taken")
    assert {*system.taken()} == {"owner", "owner-again"}
