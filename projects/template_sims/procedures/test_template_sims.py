"""Test procedure: the whole system with both simulators, driven as an operator would.

ADAPT: drive your system as its users would and check what the robots did.
`RunningProject` starts `mrss supervise <this project>` in a temporary run folder; the
simulators run 20 times faster than real time (MRSS_SIM_SPEEDUP).
"""

from __future__ import annotations

from pathlib import Path

import pytest

from mrss.api import distance_m
from mrss.api.testing import RunningProject

PROJECT = Path(__file__).resolve().parent.parent      # this project's folder
UGV_TARGET = (48.2086, 16.3742)                         # ~60 m from the UGV's base
UAV_TARGET = (48.2090, 16.3745)                         # ~100 m from the UAV's home


def position(system: RunningProject, robot: str) -> tuple[float, float] | None:
    found = ((system.world(robot) or {}).get("position") or {})
    return (found["lat"], found["lon"]) if "lat" in found else None


@pytest.mark.slow
def test_operator_goals_move_both_robots(tmp_path: Path) -> None:
    with RunningProject(PROJECT, tmp_path / "run", env={"MRSS_SIM_SPEEDUP": "20"}) as system:
        system.wait_ready()
        system.wait_for(lambda: position(system, "uav1") and position(system, "ugv1"), 20,
                        "telemetry of both robots in the world model")

        system.publish("mrss/ui/goto", {"goal": "g1", "robot": "ugv1",
                                        "lat": UGV_TARGET[0], "lon": UGV_TARGET[1]})
        system.publish("mrss/ui/goto", {"goal": "g2", "robot": "uav1",
                                        "lat": UAV_TARGET[0], "lon": UAV_TARGET[1]})

        system.wait_for(lambda: system.statuses("ugv1", "succeeded"), 60, "the UGV's drive")
        system.wait_for(lambda: system.statuses("uav1", "succeeded"), 60, "the UAV's flight")
        assert system.perceived("goto_received(g1,ugv1,")

        def arrived(robot: str, target: tuple[float, float]) -> bool:
            at = position(system, robot)
            return at is not None and distance_m(*at, *target) < 5.0

        system.wait_for(lambda: arrived("ugv1", UGV_TARGET), 10, "the UGV at its point")
        system.wait_for(lambda: arrived("uav1", UAV_TARGET), 10, "the UAV at its point")

        assert system.interrupt() == 0      # Ctrl-C stops everything cleanly
