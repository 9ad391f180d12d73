"""Fleet procedure: a UAV whose link is lost mid-cover hands its area to another UAV,
which finishes it from where the first one stopped.

`mrss supervise wildfire` as a real process: three simulated UAVs and two UGVs, each its
own process. The agent asks for the cover of an operator's area with a task addressed to
a role (`cover(any([uav, camera]), a1)`); the RCL awards it to uav1 (all three idle and
no place to rank them by: the tie goes to the smallest id). Once uav1 has reached a few
waypoints its simulator process is killed (SIGKILL), as a UAV lost for good: the project
runs from a copy whose uav1 simulator is `restart = "temporary"`, so no supervisor
brings it back. uav1's MAVLink link hears no heartbeat past its timeout and uav1 is
lost. The RCL hands the same action
to another UAV (uav2: the next tie), which starts at the waypoint uav1 had reached and
flies the rest; the agent hears `reassigned(...)` and its intention never sees the cover
fail.

A UGV the operator drives (switched by the project's `teleop_mode` skill, its status
saying teleop) is given no supply task: it goes to the other UGV, and once handed back
the UGV is given the next one.
"""

from __future__ import annotations

import re
import shutil
import signal
from pathlib import Path
from typing import Any

import pytest

from mrss.api import distance_m
from mrss.api.testing import RunningProject

PROJECT = Path(__file__).resolve().parent.parent
AREA = {"goal": "a1", "priority": 2, "center": [-35.360567, 149.165237], "radius": 100}


def waypoint(progress: dict[str, object], key: str = "waypoint") -> int:
    return int(str(progress.get(key, 0) or 0))


def lost_for_good(tmp_path: Path) -> Path:
    """A copy of the project whose uav1 simulator is not restarted once it dies."""
    copy = tmp_path / "projects" / PROJECT.name
    shutil.copytree(PROJECT, copy, ignore=shutil.ignore_patterns("__pycache__", "procedures"))
    toml = copy / "project.toml"
    head = '[components.sim_uav]\nkind = "sim_uav"\n'
    text = toml.read_text(encoding="utf-8")
    assert head in text
    toml.write_text(text.replace(head, head + 'restart = "temporary"\n'), encoding="utf-8")
    return copy


def covering(system: RunningProject) -> Any:
    """The system up, the operator's area asked, and its cover on uav1 past its second
    waypoint: that cover's status."""
    system.wait_ready()
    system.wait_for(lambda: all((system.world(r) or {}).get("position")
                                for r in ("uav1", "uav2", "uav3")), 30,
                    "the three UAVs' telemetry in the world model")
    system.publish("mrss/ui/area", AREA)
    cover = system.wait_for(lambda: system.statuses("uav1", "running"), 30,
                            "the cover to run on uav1")[0]
    system.wait_for(lambda: waypoint(system.progress(cover.uuid)) >= 2, 30,
                    "uav1 past its second waypoint")
    return cover


@pytest.mark.slow
def test_a_uav_lost_mid_cover_hands_the_area_to_another_that_goes_on_from_there(
        tmp_path: Path) -> None:
    with RunningProject(lost_for_good(tmp_path), tmp_path / "run",
                        env={"MRSS_SIM_SPEEDUP": "20"}) as system:
        cover = covering(system)

        system.signal("sim_uav", signal.SIGKILL)  # uav1 is gone, its link silent
        handed = system.wait_for(
            lambda: [s for s in system.statuses("uav2", "running") if s.uuid == cover.uuid],
            30, "the cover to run on uav2")[0]

        # the same action went back to allocation with the progress uav1 recorded ...
        gone = [s for s in system.statuses() if s.uuid == cover.uuid
                and s.state == "pending" and not s.robot]
        assert gone, [(s.state, s.robot, s.reason) for s in system.statuses()]
        # uav1's loss, as whichever sees it first tells it: the link's watch, or the
        # cover's own skill whose link went silent
        assert re.match(r"reassigning: (robot uav1 unreachable|CoverArea raised LinkDown: "
                        r"robot uav1: )", gone[0].reason), gone[0]
        reached = waypoint(gone[0].progress)
        total = waypoint(gone[0].progress, "waypoints")
        assert 2 <= reached < total, gone[0].progress
        assert waypoint(gone[0].progress, "first") == 0  # uav1 had started the area
        assert handed.uuid == cover.uuid

        done = system.wait_for(lambda: [s for s in system.statuses("uav2", "succeeded")
                                        if s.uuid == cover.uuid], 60,
                               "uav2 to finish the area")[0]
        assert waypoint(done.progress) == waypoint(done.progress, "waypoints") == total
        assert waypoint(done.progress, "first") == reached  # uav2 started where uav1 stopped
        # the agent was told, and its intention went on waiting: one cover, never failed
        assert system.perceived("reassigned(cover(any([uav,camera]),a1), uav1, uav2)"), \
            system.perceived("reassigned")
        assert {s.uuid for s in system.statuses() if s.uuid == cover.uuid} == {cover.uuid}
        assert not [s for s in system.statuses() if s.uuid == cover.uuid
                    and s.state in ("failed", "cancelled")], system.log()
        assert len({s.uuid for s in system.statuses("uav2")}) == 1  # no second cover
        assert not system.statuses("uav3")                          # uav3 was not needed
        # uav2 flew the rest: it is at the area's last waypoint, far from its home
        uav2 = system.world("uav2")
        assert uav2 is not None
        home = (-35.363262, 149.166118)
        assert distance_m(uav2["position"]["lat"], uav2["position"]["lon"], *home) > 150
        assert system.component_pid("sim_uav") == 0  # not brought back: lost for good
        assert system.interrupt() == 0, system.log()


def hotspot(system: RunningProject, ident: int, lat: float, lon: float) -> None:
    """uav1's thermal camera reports a hotspot (as its link would)."""
    system.link_data("uav1", {"type": "hotspot", "id": ident, "lat": lat, "lon": lon,
                              "temperature": 450.0})


def teleop(system: RunningProject, on: bool) -> None:
    """The operator switches ugv1 to teleoperation and back: the agent's plan runs the
    project's teleop skill, and the robot's own status says so."""
    system.publish("mrss/ui/teleop", {"robot": "ugv1", "on": on})
    system.wait_for(lambda: (system.world("ugv1") or {}).get("attributes", {})
                    .get("teleop") is on, 20, f"ugv1 to report teleop {on}")


@pytest.mark.slow
def test_a_ugv_teleoperated_by_the_projects_skill_is_given_no_task_until_handed_back(
        tmp_path: Path) -> None:
    with RunningProject(PROJECT, tmp_path / "run", env={"MRSS_SIM_SPEEDUP": "20"}) as system:
        system.wait_ready()
        system.wait_for(lambda: all((system.world(r) or {}).get("position")
                                    for r in ("uav1", "ugv1", "ugv2")), 30,
                        "the robots' telemetry in the world model")
        teleop(system, True)
        # far from the pond, and nearer ugv1 (350 m) than ugv2 (500 m): ugv2 takes it,
        # for ugv1 is in its operator's hands (its skill would only wait)
        hotspot(system, 1, -35.360387, 149.165678)
        first = system.wait_for(lambda: [s for s in system.statuses("ugv2", "running")
                                         if s.name == "supply_water"], 30,
                                "the supply of hs1 to run on ugv2")[0]
        assert not [s for s in system.statuses("ugv1") if s.name == "supply_water"]
        teleop(system, False)
        # next to ugv1's base: back in autonomy, it is given the next one
        hotspot(system, 5, -35.3630, 149.1650)
        second = system.wait_for(lambda: [s for s in system.statuses("ugv1", "running")
                                          if s.name == "supply_water"], 30,
                                 "the supply of hs5 to run on ugv1")[0]
        assert second.uuid != first.uuid
        assert not system.statuses(state="failed"), system.log()
        assert system.interrupt() == 0, system.log()


@pytest.mark.slow
def test_a_cover_asked_again_at_a_new_priority_goes_on_from_the_waypoint_reached(
        tmp_path: Path) -> None:
    with RunningProject(PROJECT, tmp_path / "run", env={"MRSS_SIM_SPEEDUP": "20"}) as system:
        cover = covering(system)
        # uav1 answers nothing for a while (its simulator frozen): its cover, withdrawn,
        # takes that long to stop. The agent withdraws it and asks it again at priority
        # 5; an idle UAV is given the new one at once, while uav1's is still stopping
        system.signal("sim_uav", signal.SIGSTOP)
        try:
            system.publish("mrss/ui/priority", {"goal": "a1", "priority": 5})
            again = system.wait_for(lambda: [s for s in system.statuses(state="running")
                                             if s.name == "cover" and s.uuid != cover.uuid],
                                    30, "the cover asked again to run")[0]
        finally:
            system.signal("sim_uav", signal.SIGCONT)
        ended = system.wait_for(lambda: [s for s in system.statuses("uav1")
                                         if s.uuid == cover.uuid and s.state in
                                         ("cancelled", "failed")], 30,
                                "uav1's cover withdrawn")[-1]
        reached = waypoint(ended.progress)
        assert reached >= 2, ended.progress
        done = system.wait_for(lambda: [s for s in system.statuses(state="succeeded")
                                        if s.uuid == again.uuid], 60,
                               "the cover asked again to finish")[0]
        # it started where uav1 had stopped: it waited for uav1's cover to end
        assert waypoint(done.progress, "first") == reached, (done.robot, done.progress)
        assert waypoint(done.progress) == waypoint(done.progress, "waypoints")
        assert done.robot != "uav1"
        assert system.interrupt() == 0, system.log()
