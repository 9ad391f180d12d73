"""End-to-end procedure: `mrss supervise wildfire` as a real process, driven like an operator.

An operator area goal goes in over MQTT; the simulated UAV (MAVLink over UDP) covers the
area and its thermal camera finds the two hidden hotspots; the world model rule sends
the UGV (MQTT) to the one with no water nearby; on its way the operator switches it to
teleoperation and back (its goal is suspended, then resumed); it pumps 60 l there;
SIGINT then stops everything: exit code 0, no process left. Everything is checked from
the outside: on the bus (statuses, percepts) and through the world model's HTTP API.

The simulators run 20 times faster than real time (MRSS_SIM_SPEEDUP); about 20 s.
"""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

import pytest

from mrss.api import distance_m
from mrss.api.testing import RunningProject

PROJECT = Path(__file__).resolve().parent.parent
HOTSPOT_1 = (-35.360387, 149.165678)       # far from the pond: the UGV must go
CONSOLE = PROJECT / "operator_console.py"


def operator(run_dir: Path, *command: str) -> subprocess.CompletedProcess[str]:
    """The operator's console, as a user runs it (it waits for the system's answer)."""
    return subprocess.run([sys.executable, str(CONSOLE), "--run-dir", str(run_dir),
                           *command], capture_output=True, text=True, timeout=60)


@pytest.mark.slow
def test_area_goal_to_water_on_the_hotspot(tmp_path: Path) -> None:
    with RunningProject(PROJECT, tmp_path / "run", env={"MRSS_SIM_SPEEDUP": "20"}) as system:
        system.wait_ready()

        def robots_reporting() -> bool:   # telemetry reaches the world model: links are up
            uav, ugv = system.world("uav1"), system.world("ugv1")
            return bool(uav and uav.get("position") and ugv and ugv.get("position"))

        system.wait_for(robots_reporting, 20, "telemetry of both robots in the world model")

        sent = operator(tmp_path / "run", "area", "a1", "--center=-35.360567,149.165237",
                        "--radius", "100", "-p", "2")
        assert sent.returncode == 0 and sent.stdout.rstrip().endswith("-> accepted"), sent
        refused = operator(tmp_path / "run", "area", "a0", "--polygon=-35.36,149.16")
        assert refused.returncode == 1 and "-> rejected: " in refused.stdout, refused

        # the UAV covers the area; its thermal camera sees both hidden hotspots
        covered = system.wait_for(lambda: system.statuses("uav1", "succeeded"), 40,
                                  "the cover action to succeed")[0]
        assert covered.progress["waypoint"] == covered.progress["waypoints"]
        hs1, hs2 = system.world("hs1"), system.world("hs2")
        assert hs1 is not None and hs2 is not None, system.log()
        assert distance_m(hs1["position"]["lat"], hs1["position"]["lon"], *HOTSPOT_1) < 1.0
        assert hs1["attributes"]["seen_by"] == "uav1"

        # only the hotspot with no water source within 150 m is sent to the UGV ...
        supply = system.wait_for(lambda: system.statuses("ugv1", "running"), 20,
                                 "the supply action to run")[0]

        # ... and the operator takes it over on the way (paper VI): its goal is suspended
        # and the teleop skill switches the robot to direct control; back in autonomy,
        # the goal goes on from where it stopped
        assert operator(tmp_path / "run", "teleop", "ugv1", "on").returncode == 0
        system.wait_for(lambda: [s for s in system.statuses("ugv1", "suspended")
                                 if s.uuid == supply.uuid], 10, "the supply to be suspended")
        system.wait_for(lambda: (system.world("ugv1") or {}).get("attributes", {})
                        .get("teleop"), 10, "the UGV to report teleoperation")
        assert not [s for s in system.statuses("ugv1", "succeeded") if s.uuid == supply.uuid]
        assert operator(tmp_path / "run", "teleop", "ugv1", "off").returncode == 0

        supplied = system.wait_for(lambda: [s for s in system.statuses("ugv1", "succeeded")
                                            if s.uuid == supply.uuid], 40,
                                   "the supply action to succeed")[0]
        switches = [s for s in system.statuses("ugv1", "succeeded") if s.uuid != supply.uuid]
        assert len(switches) == 2                      # teleop_mode(ugv1, on), then off
        assert system.perceived("hotspot_detected(hs1,")
        assert not system.perceived("hotspot_detected(hs2,")
        assert supplied.progress["pumped"] >= 59.5
        ugv = system.world("ugv1")
        assert ugv is not None
        assert distance_m(ugv["position"]["lat"], ugv["position"]["lon"], *HOTSPOT_1) < 5.0
        system.wait_for(lambda: (system.world("ugv1") or {}).get("attributes", {})
                        .get("water", 200) <= 141, 10, "the tank to show the 60 l pumped")
        assert not system.statuses(state="failed"), system.log()
        # the dashboard's map colours hotspots by the state the supply skill gave them
        system.wait_for(lambda: (system.world("hs1") or {}).get("attributes", {})
                        .get("state") == "supplied", 10, "hs1 supplied in the world model")
        assert "state" not in (system.world("hs2") or {}).get("attributes", {})

        # Ctrl-C: everything stops, exit code 0, no process left behind
        assert system.interrupt() == 0, system.log()
