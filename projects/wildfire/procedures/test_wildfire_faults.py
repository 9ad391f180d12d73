"""Fault procedure: the wildfire mission survives a reasoner killed in the middle of a
cover, and an RCL killed in the middle of the water supply that follows.

`mrss supervise wildfire` as a real process. An operator area goal goes in over MQTT;
while the UAV covers the area, the reasoner process is SIGKILLed. Its supervisor starts
a new incarnation, which perceives the standing goal again (its percept ledger), asks
the RCL what its predecessor left and adopts the running cover: the same action (same
uuid) goes on from its progress to the end, no second cover is requested, and the
mission goes on from there: the hotspot found is sent water. While the UGV drives there,
the RCL process is SIGKILLed: its new incarnation restores the supply from its journal
and it goes on to the end (chaos campaigns: the restored skill's first command used to
fail at once, "connecting to ...", because the new link had not reached the broker yet).
"""

from __future__ import annotations

import signal
from pathlib import Path

import pytest

from mrss.api.testing import RunningProject

PROJECT = Path(__file__).resolve().parent.parent
AREA = {"goal": "a1", "priority": 2, "center": [-35.360567, 149.165237], "radius": 100}


@pytest.mark.slow
def test_a_reasoner_killed_mid_cover_is_replaced_and_the_cover_is_adopted(
        tmp_path: Path) -> None:
    with RunningProject(PROJECT, tmp_path / "run", env={"MRSS_SIM_SPEEDUP": "20"}) as system:
        system.wait_ready()
        system.wait_for(lambda: (system.world("uav1") or {}).get("position"), 20,
                        "UAV telemetry in the world model")
        system.publish("mrss/ui/area", AREA)
        cover = system.wait_for(lambda: system.statuses("uav1", "running"), 30,
                                "the cover to run")[0]
        system.wait_for(lambda: int(system.progress(cover.uuid).get("waypoint", 0) or 0) >= 1,
                        30, "the cover past its first waypoint")

        system.signal("reasoner", signal.SIGKILL)
        killed_at = system.progress(cover.uuid)  # mid-cover: waypoints were left to fly
        assert int(str(killed_at["waypoint"])) < int(str(killed_at["waypoints"])), killed_at
        system.wait_for(lambda: system.incarnation("reasoner") >= 2, 20,
                        "a new reasoner incarnation")

        done = system.wait_for(lambda: [s for s in system.statuses("uav1", "succeeded")
                                        if s.uuid == cover.uuid], 60,
                               "the adopted cover to succeed")[0]
        assert done.progress["waypoint"] == done.progress["waypoints"]
        states = [s.state for s in system.statuses() if s.uuid == cover.uuid]
        assert "cancelled" not in states and "failed" not in states, states
        covers = {s.uuid for s in system.statuses("uav1")}
        assert covers == {cover.uuid}, "a second cover was started instead of adopting"

        # the mission goes on under the new incarnation: the hotspot gets water, although
        # the RCL is killed on the way
        supply = system.wait_for(lambda: system.statuses("ugv1", "running"), 60,
                                 "the water supply to run")[0]
        system.signal("rcl", signal.SIGKILL)
        system.wait_for(lambda: system.incarnation("rcl") >= 2, 20, "a new RCL incarnation")
        supplied = system.wait_for(lambda: [s for s in system.statuses("ugv1", "succeeded")
                                            if s.uuid == supply.uuid], 60,
                                   "the restored supply to succeed")
        assert supplied and not system.statuses(state="failed"), system.log()
        assert system.interrupt() == 0, system.log()
