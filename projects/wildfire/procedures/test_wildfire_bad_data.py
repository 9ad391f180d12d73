"""Fault procedure (issue 15): bad robot data never moves a robot.

`mrss supervise wildfire` as a real process. Records as a robot link would send them (from
the RCL, which owns the links): a `robot.fz9.data` of a robot that is not configured (a
hotspot at 0,0 at 1e308 degrees, an empty tank), and out-of-range records of the
configured robots (a hotspot at 1e308 degrees or at latitude 214.7, a battery at -128 %,
a tank at -5 L, an altitude of 2.1e6 m); and the same records from a stranger on the bus.
The data layer refuses each of them (counted, logged once per source and reason): no
world model object, no percept, and no action for ugv1; a valid hotspot the link sends
after them is taken.
"""

from __future__ import annotations

from pathlib import Path

import pytest

from mrss.api.testing import RunningProject

PROJECT = Path(__file__).resolve().parent.parent
FORGED = [
    ("fz9", {"type": "hotspot", "id": 99, "lat": 0.0, "lon": 0.0, "temperature": 1e308}),
    ("fz9", {"type": "tank", "level": 0.0, "capacity": 200.0, "pumping": False}),
    ("uav1", {"type": "hotspot", "id": 98, "lat": 0.0, "lon": 0.0, "temperature": 1e308}),
    ("uav1", {"type": "hotspot", "id": 97, "lat": 214.7, "lon": 0.0, "temperature": 400.0}),
    ("uav1", {"type": "battery", "remaining": -128.0, "voltage": None, "current": None}),
    ("ugv1", {"type": "tank", "level": -5.0, "capacity": 200.0, "pumping": False}),
    ("ugv1", {"type": "position", "lat": 0.0, "lon": 0.0, "alt": 2.1e6, "heading": None}),
]
REASONS = ["from rcl: robot 'fz9' is not in the project",
           "from procedure: not from rcl, the owner of its link",
           "from uav1: hotspot.temperature out of range",
           "from uav1: hotspot.lat out of range", "from uav1: battery.remaining out of range",
           "from ugv1: tank.level out of range", "from ugv1: position.alt out of range"]
# by the pond: a hotspot the world model keeps without asking for water
MARKER = {"type": "hotspot", "id": 96, "lat": -35.361196, "lon": 149.164576,
          "temperature": 350.0}


@pytest.mark.slow
def test_forged_and_out_of_range_robot_data_make_no_object_no_percept_no_action(
        tmp_path: Path) -> None:
    with RunningProject(PROJECT, tmp_path / "run", env={"MRSS_SIM_SPEEDUP": "8"}) as system:
        system.wait_ready()
        system.wait_for(lambda: (system.world("ugv1") or {}).get("position"), 30,
                        "UGV telemetry in the world model")

        def taken() -> dict[str, object] | None:
            for _ in range(2):  # twice: the second is only counted
                for robot, data in FORGED:
                    system.link_data(robot, data)
                    system.robot_data(robot, data)  # a stranger's: refused at the door
            system.link_data("uav1", MARKER)
            return system.world("hs96")
        # (the first messages may go out before the proxy forwards this new publisher)
        system.wait_for(taken, 30, "the valid hotspot after the forged data")

        for ident in ("hs99", "hs98", "hs97", "fz9"):
            assert system.world(ident) is None, ident
        position = (system.world("ugv1") or {}).get("position") or {}
        assert abs(float(position["lat"]) + 35.36) < 0.1, position  # never at 0,0
        assert not system.perceived("hotspot_detected(hs9")
        assert not system.perceived("water_low(") and not system.perceived("battery_low(")
        assert not system.statuses("ugv1"), "ugv1 was sent somewhere"
        log = system.log(tail=400_000)
        for reason in REASONS:
            assert f"refused robot data {reason}" in log, reason
        assert "Traceback" not in log
        assert system.interrupt() == 0, system.log()
