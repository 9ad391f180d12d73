"""Test procedure of this project: the whole system as `mrss supervise` runs it.

ADAPT: drive your system as its users would (MQTT events, HTTP) and check what the
robots did. `mrss.procedures.RunningProject` starts `mrss supervise <this project>` as a
process in a temporary run folder and watches the bus, the world model and the broker.
`make test` runs every procedures/test_*.py (mark slow ones with pytest.mark.slow).
"""

from __future__ import annotations

from pathlib import Path

import pytest

from mrss.api import distance_m
from mrss.api.testing import RunningProject

PROJECT = Path(__file__).resolve().parent.parent      # this project's folder
TARGET = (48.2090, 16.3745)                             # ~100 m from the robot's home
HOME = (48.2082, 16.3738)                               # project.toml's robot1 home


@pytest.mark.slow
def test_operator_goal_is_reached(tmp_path: Path) -> None:
    with RunningProject(PROJECT, tmp_path / "run") as system:
        system.wait_ready()
        system.wait_for(lambda: system.world("robot1"), 10, "robot1 telemetry")

        system.publish("mrss/ui/goto", {"goal": "g1", "lat": TARGET[0], "lon": TARGET[1]})
        system.publish("mrss/ui/goto", {"goal": "bad one", "lat": 1, "lon": 2})  # refused

        done = system.wait_for(lambda: system.statuses("robot1", "succeeded"), 20,
                               "the move action to succeed")
        assert system.perceived("goto_received(g1,")
        assert not system.perceived("goto_received(\"bad")
        assert done[0].progress["travelled_m"] > 50

        def at_target() -> bool:            # telemetry reached the world model
            position = (system.world("robot1") or {}).get("position") or {}
            return distance_m(position["lat"], position["lon"], *TARGET) < 1.0

        system.wait_for(at_target, 5, "robot1 at the target in the world model")

        # a goal addressed to a role: the RCL gives it to robot1, the one ground robot
        system.publish("mrss/ui/inspect", {"goal": "i1", "lat": HOME[0], "lon": HOME[1]})
        inspected = system.wait_for(
            lambda: [s for s in system.statuses("robot1", "succeeded") if s.goal == "i1"],
            20, "the inspect goal's move to succeed on robot1")
        assert inspected[0].name == "move" and system.perceived("inspect_received(i1,")

        assert system.interrupt() == 0      # Ctrl-C stops everything cleanly
