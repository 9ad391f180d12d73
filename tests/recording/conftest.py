"""A recording of the wildfire procedure, made once for the tests that read it."""

from __future__ import annotations

import signal
import subprocess
import sys
from contextlib import closing
from pathlib import Path

import pytest

from mrss.api.testing import RunningProject
from tests.commands.cli_bus import mrss_process

WILDFIRE = Path(__file__).resolve().parents[2] / "projects" / "wildfire"


def _operator(run_dir: Path, *command: str) -> None:
    """The project's operator console, as a user runs it (it waits for the answer)."""
    out = subprocess.run([sys.executable, str(WILDFIRE / "operator_console.py"),
                          "--run-dir", str(run_dir), *command],
                         capture_output=True, text=True, timeout=60)
    assert out.returncode == 0 and out.stdout.rstrip().endswith("-> accepted"), out


@pytest.fixture(scope="session")
def wildfire_recording(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """`mrss record --project wildfire` of the procedure: the operator's area goal a1,
    the events manager SIGKILLed (restarted), the operator's teleop of ugv1 (on), the
    UAV finding hotspot hs1 while covering, teleop off, the supply of hs1 by ugv2 (ugv1
    was in the operator's hands when it was asked), the cover done."""
    tmp_path = tmp_path_factory.mktemp("wildfire-recording")
    out = tmp_path / "wildfire.mcap"
    run_dir = tmp_path / "run"
    # a loaded machine may take a minute to start the fork server and the proxy
    with closing(RunningProject(WILDFIRE, run_dir, env={"MRSS_SIM_SPEEDUP": "20"})
                 .start(timeout=90)) as system:
        with mrss_process("record", "--run-dir", str(run_dir), "--out", str(out),
                          "--project", str(WILDFIRE), "--timeout", "30") as rec:
            rec.wait_line("recording ", timeout=30)
            system.wait_ready()
            system.wait_for(lambda: (system.world("uav1") or {}).get("position")
                            and (system.world("ugv1") or {}).get("position"), 30,
                            "telemetry of both robots")
            _operator(run_dir, "area", "a1", "--center=-35.360567,149.165237",
                      "--radius", "100", "-p", "2")
            killed = system.signal("events", signal.SIGKILL)  # a fault: restarted
            system.wait_for(lambda: system.component_pid("events") not in (0, killed), 60,
                            "the events manager restarted")
            # the operator takes ugv1 over before the UAV finds the hotspot: the RCL gives
            # the supply to ugv2 (ugv1's status says teleop)
            _operator(run_dir, "teleop", "ugv1", "on")
            system.wait_for(lambda: (system.world("ugv1") or {}).get("attributes", {})
                            .get("teleop"), 30, "ugv1 to report teleoperation")
            system.wait_for(lambda: system.perceived("hotspot_detected(hs1,"), 90,
                            "the hotspot found")
            _operator(run_dir, "teleop", "ugv1", "off")
            system.wait_for(lambda: system.statuses("uav1", "succeeded"), 90, "the cover")
            system.wait_for(lambda: [s for s in system.statuses("ugv2", "succeeded")
                                     if s.name == "supply_water"], 90, "the supply done")
            rec.proc.send_signal(signal.SIGINT)
            assert rec.finish() == 0, rec.stderr()
        assert system.interrupt() == 0
    return out
