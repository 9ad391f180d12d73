"""A real recording of the wildfire mission, for the replay tests: `mrss supervise
wildfire` as a process (simulators 20x), `mrss record --project wildfire` as a process,
an operator area goal through the project's console; recorded until the UGV's water
supply has succeeded, then the recorder is stopped with SIGINT (a finished file)."""

from __future__ import annotations

import signal
import subprocess
import sys
from contextlib import closing
from pathlib import Path

from mrss.api.testing import RunningProject
from tests.commands.cli_bus import mrss_process

WILDFIRE = Path(__file__).resolve().parents[2] / "projects" / "wildfire"
START_TIMEOUT = 60.0  # its fork server imports every component first: slow on a busy box


def record_wildfire(out: Path, run_dir: Path) -> None:
    """Record one wildfire mission (area goal, hotspots found, water supplied) to `out`."""
    system = RunningProject(WILDFIRE, run_dir, env={"MRSS_SIM_SPEEDUP": "20"})
    with closing(system.start(timeout=START_TIMEOUT)):
        with mrss_process("record", "--run-dir", str(run_dir), "--out", str(out),
                          "--project", str(WILDFIRE), "--timeout", "30") as rec:
            rec.wait_line("recording ", timeout=30)
            system.wait_ready()
            system.wait_for(lambda: (system.world("uav1") or {}).get("position")
                            and (system.world("ugv1") or {}).get("position"), 30,
                            "telemetry of both robots in the world model")
            sent = subprocess.run(
                [sys.executable, str(WILDFIRE / "operator_console.py"), "--run-dir",
                 str(run_dir), "area", "a1", "--center=-35.360567,149.165237",
                 "--radius", "100", "-p", "2"], capture_output=True, text=True, timeout=60)
            assert sent.returncode == 0, sent
            system.wait_for(lambda: system.statuses("ugv1", "succeeded"), 120,
                            "the UGV's water supply to succeed")
            rec.proc.send_signal(signal.SIGINT)
            assert rec.finish() == 0, rec.stderr()
        assert system.interrupt() == 0, system.log()
