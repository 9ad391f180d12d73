"""`mrss new NAME --with-sims`: the template wired to both simulators runs as made.

The copy is checked by `mrss check` and then run by `mrss supervise` (RunningProject):
an operator's MQTT event becomes a percept, the agent's action a skill on the
simulated UGV over its MQTT link, and the action succeeds with the robot at the point.
"""

from __future__ import annotations

import os
import re
import subprocess
import sys
from pathlib import Path

import pytest

from mrss.api import distance_m
from mrss.api.testing import RunningProject

TARGET = (48.2086, 16.3742)         # ~60 m from the UGV's base in the variant


def mrss(projects: Path, *args: str) -> subprocess.CompletedProcess[str]:
    env = dict(os.environ, MRSS_PROJECTS=str(projects))
    return subprocess.run([sys.executable, "-m", "mrss", *args], capture_output=True,
                          text=True, timeout=120, env=env)


def test_with_sims_is_refused_with_another_source(tmp_path: Path) -> None:
    out = mrss(tmp_path, "new", "demo", "--with-sims", "--from", "wildfire")
    assert out.returncode == 2
    assert "--with-sims" in out.stderr and "wildfire" in out.stderr
    assert not (tmp_path / "demo").exists()


@pytest.mark.slow
def test_new_with_sims_checks_and_moves_a_robot(tmp_path: Path) -> None:
    projects = tmp_path / "projects"
    out = mrss(projects, "new", "demo", "--with-sims")
    assert out.returncode == 0, out.stderr
    folder = projects / "demo"
    assert re.search(r'^name = "demo"', (folder / "project.toml").read_text(), re.M)
    assert (folder / "procedures" / "test_demo.py").is_file()

    check = mrss(projects, "check", "demo")
    assert check.returncode == 0, check.stdout + check.stderr
    assert "robots: uav1 (mavlink), ugv1 (mqtt)" in check.stdout
    assert "actions drive/4, fly/4" in check.stdout

    with RunningProject(folder, tmp_path / "run", env={"MRSS_SIM_SPEEDUP": "20"}) as s:
        s.wait_ready()
        s.wait_for(lambda: (s.world("ugv1") or {}).get("position"), 20, "UGV telemetry")
        s.publish("mrss/ui/goto", {"goal": "g1", "robot": "ugv1",
                                   "lat": TARGET[0], "lon": TARGET[1]})
        done = s.wait_for(lambda: s.statuses("ugv1", "succeeded"), 60, "the drive")
        assert s.perceived("goto_received(g1,ugv1,")
        assert not s.statuses("ugv1", "failed"), s.log()
        assert done[0].uuid

        def arrived() -> bool:
            at = (s.world("ugv1") or {}).get("position") or {}
            return "lat" in at and distance_m(at["lat"], at["lon"], *TARGET) < 5.0

        s.wait_for(arrived, 10, "the UGV at the point in the world model")
        assert s.interrupt() == 0
