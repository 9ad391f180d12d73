"""Stand-down by area through real processes: two simulated UAVs (`mrss sim uav`, each a
process speaking MAVLink over UDP, uav2 400 m east of uav1), a bus proxy and the RCL
under the root supervisor. The test plays the reasoner (requests on the reliable action
channel) and the operator (`ctl.stand_down`, `ctl.stand_down_lift`)."""

from __future__ import annotations

import sqlite3
from collections.abc import Iterator
from pathlib import Path
from typing import Any

import pytest

from mrss.links.geo import offset
from mrss.messages import (
    ActionState,
    Command,
    RobotData,
    RobotState,
    StandDownMode,
    StandDownState,
)
from mrss.supervision.faults import kill
from mrss.testing import wait_until
from tests.actors.rcl.processes import Procs
from tests.actors.rcl.test_reallocation_processes import HOMES
from tests.actors.rcl.test_reallocation_processes import System as Fleet


class System(Fleet):
    """The re-allocation system, also hearing the stand-down states."""

    def __init__(self, procs: Procs, run_dir: Path) -> None:
        super().__init__(procs, run_dir, hear=("fleet.",))

    def stand_downs(self, ident: str) -> list[StandDownState]:
        return self.bodies(StandDownState, ident=ident)

    def stand_down(self, ident: str, **args: Any) -> None:
        self.pub.publish(Command(command="stand_down", target=ident, args=args))

    def lift(self, ident: str = "") -> None:
        self.pub.publish(Command(command="stand_down_lift", target=ident))

    def answer(self, ident: str, count: int = 1, timeout: float = 20) -> StandDownState:
        """The `count`-th state of stand-down `ident` (waited for)."""
        wait_until(lambda: len(self.stand_downs(ident)) >= count, timeout=timeout,
                   message=f"stand-down {ident} state #{count}")
        return self.stand_downs(ident)[count - 1]

    def suspended(self, uuid: str) -> str:
        """The reason of `uuid`'s last status if it is SUSPENDED, else ""."""
        states = self.statuses(uuid)
        return states[-1].reason if states and states[-1].state is ActionState.SUSPENDED else ""


def square(lat: float, lon: float, half_m: float) -> dict[str, Any]:
    """A GeoJSON Polygon: the square of side 2 * half_m around (lat, lon)."""
    corners = [offset(lat, lon, dn, de) for dn, de in
               ((-half_m, -half_m), (-half_m, half_m), (half_m, half_m), (half_m, -half_m))]
    ring = [[c[1], c[0]] for c in corners]
    return {"type": "Polygon", "coordinates": [[*ring, ring[0]]]}


AROUND_UAV1 = square(*HOMES["uav1"], 100.0)


@pytest.fixture()
def system(procs: Procs, run_dir: Path) -> Iterator[System]:
    s = System(procs, run_dir)
    try:
        yield s
    finally:
        s.close()


@pytest.mark.slow
def test_a_stand_down_holds_the_robots_inside_until_one_lift(system: System) -> None:
    # refusals first: each says why, and nothing is held
    system.stand_down("bad1", area={"type": "Polygon", "coordinates": [
        [[0, 0], [1, 1], [1, 0], [0, 1], [0, 0]]]}, mode="hold")
    assert "refused: area:" in system.answer("bad1").notes[0]
    system.stand_down("bad2", area=AROUND_UAV1, capabilities=["uva"])
    assert "did you mean 'uav'" in system.answer("bad2").notes[0]
    system.stand_down("bad3", area=AROUND_UAV1, mode="land")
    assert "mode 'land': expected one of hold, home" in system.answer("bad3").notes[0]
    assert not any(s.active for s in system.bodies(StandDownState))

    system.sweep("a1", steps=400, robot="uav1")
    wait_until(lambda: system.step("a1") >= 1, timeout=20, message="a1 under way")
    system.stand_down("sd1", area=AROUND_UAV1, mode="hold", capabilities=["uav"],
                      robots=["uav1", "uav2"])  # the operator thought uav2 was inside too
    made = system.answer("sd1")
    assert made.active and made.robots == ["uav1"] and made.mode is StandDownMode.HOLD
    assert made.notes[0].startswith("uav2 is outside by its last position"), made.notes
    wait_until(lambda: system.suspended("a1") == "stand-down sd1 (hold)", timeout=20,
               message="a1 suspended by the stand-down")
    kept = system.step("a1")
    system.stand_down("sd1", area=AROUND_UAV1)  # the same id again: refused, sd1 stays
    assert "is active already" in system.answer("sd1", 2).notes[0]
    # a new action for a held robot starts held; a role task goes to the robot outside
    system.sweep("a2", steps=2, robot="uav1")
    wait_until(lambda: system.suspended("a2") == "stand-down sd1 (hold)", timeout=20,
               message="a2 starts suspended")
    system.sweep("r1", steps=2, near="uav1")
    award = system.awarded("r1")
    assert award.robot == "uav2"
    assert next(b for b in award.bids if b["robot"] == "uav1")["unfit"] == "unavailable"
    assert system.ended("r1").state is ActionState.SUCCEEDED
    assert system.step("a1") == kept  # held all along
    with sqlite3.connect(str(system.journal())) as db:
        assert [r[0] for r in db.execute("SELECT ident FROM stand_downs")] == ["sd1"]

    system.lift()  # one command: every active stand-down
    lifted = system.answer("sd1", 3)
    assert not lifted.active and lifted.robots == ["uav1"]
    assert system.ended("a2").state is ActionState.SUCCEEDED
    wait_until(lambda: system.step("a1") > kept, timeout=20, message="a1 goes on")
    resumed = next(s for s in system.statuses("a1") if s.state is ActionState.RUNNING
                   and s.reason.startswith("resumed"))
    assert resumed.robot == "uav1"
    with sqlite3.connect(str(system.journal())) as db:
        assert db.execute("SELECT COUNT(*) FROM stand_downs").fetchone() == (0,)


@pytest.mark.slow
def test_a_stand_down_home_sends_the_copter_home_and_outlives_an_rcl_restart(
        system: System) -> None:
    system.sweep("h1", steps=400, robot="uav2")
    wait_until(lambda: system.step("h1") >= 1, timeout=20, message="h1 under way")
    system.stand_down("sd2", area=square(*HOMES["uav2"], 50.0), mode="home")
    assert system.answer("sd2").robots == ["uav2"]
    wait_until(lambda: system.suspended("h1").startswith("stand-down sd2"), timeout=20,
               message="h1 suspended")

    def mode(robot: str) -> str:
        modes = [d.data.get("mode") for d in system.bodies(RobotData, robot=robot)
                 if d.data.get("type") == "status"]
        return str(modes[-1]) if modes else ""

    wait_until(lambda: mode("uav2") == "RTL", timeout=20, message="uav2 in RTL")
    assert mode("uav1") != "RTL"

    kill(system.sup, "rcl")  # SIGKILL; the root supervisor restarts it
    wait_until(lambda: any(e.inc == 2 and isinstance(e.body, StandDownState)
                           and e.body.ident == "sd2" and e.body.active
                           for e in list(system.seen)), timeout=30,
               message="the restarted RCL announces sd2 still active")
    # once its link has reported to the new RCL (before, a request for it is refused)
    wait_until(lambda: any(e.inc == 2 and isinstance(e.body, RobotState)
                           and e.body.robot == "uav2" and e.body.available
                           for e in list(system.seen)), timeout=30, message="uav2 back")
    system.sweep("h2", steps=2, robot="uav2")  # held after the restart too
    wait_until(lambda: system.suspended("h2").startswith("stand-down sd2"), timeout=20,
               message="h2 starts suspended")
    system.lift("sd2")
    assert system.ended("h2", timeout=30).state is ActionState.SUCCEEDED
    wait_until(lambda: not system.suspended("h1"), timeout=20, message="h1 resumed")
