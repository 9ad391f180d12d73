"""Re-allocation through real processes: two simulated UAVs (`mrss sim uav`, each a
process speaking MAVLink over UDP), a bus proxy and the RCL under the root supervisor.
The test plays the reasoner (role-addressed `ActionRequest`s on the reliable action
channel) and the operator (`ctl.decommission`), and takes a robot away by freezing its
simulator (SIGSTOP: its link hears nothing past its heartbeat timeout)."""

from __future__ import annotations

import json
import signal
import sqlite3
from collections.abc import Iterator
from pathlib import Path
from typing import Any

import pytest

from mrss.links.geo import offset
from mrss.messages import (
    ActionRequest,
    ActionState,
    AllocationState,
    Command,
    FailureCause,
    Percept,
    RobotData,
    RobotState,
    TaskAllocation,
)
from mrss.sim.uav import DEFAULT_HOME
from mrss.supervision.faults import kill
from mrss.testing import wait_until
from tests.actors.rcl.processes import Bus, Procs, rcl_child, root, uav_sim_child

PROJECT = Path(__file__).parent / "reallocation_project"
HOMES = {"uav1": DEFAULT_HOME[:2], "uav2": offset(DEFAULT_HOME[0], DEFAULT_HOME[1], 400.0, 0)}


class System(Bus):
    """Two simulated UAVs and the RCL on a bus; what the test heard."""

    def __init__(self, procs: Procs, run_dir: Path, hear: tuple[str, ...] = ()) -> None:
        super().__init__(procs, run_dir, ["action.", "percept", "robot.uav", *hear])
        robots = {r: {"link": "mavlink", "heartbeat_timeout": 3.0,  # a loaded CI host
                      "capabilities": ["uav", "camera"], "cruise_speed": 10.0}
                  for r in HOMES}
        sims = [uav_sim_child(r, [*home, 584.0]) for r, home in HOMES.items()]
        self.sup = root(PROJECT, run_dir, self.endpoints,
                        [*sims, rcl_child({"robots": robots, "heartbeat": 0.2})],
                        intensity=10, heartbeat_misses=100)
        self.sup.start()
        assert self.sup.wait_started(60), "the simulators and the RCL did not start"
        for robot in HOMES:  # telemetry flows: its link is up, its position known (a
            # position record: the link keeps it before it goes on the bus; a first status
            # or battery record alone left a bid "position unknown": a run under load)
            wait_until(lambda r=robot: any(  # type: ignore[misc]
                b.data.get("type") == "position" for b in self.bodies(RobotData, robot=r)),
                timeout=30, message=f"{robot}'s position")

    def close(self) -> None:
        self.sup.stop(timeout=30)
        super().close()

    def sweep(self, uuid: str, steps: int, near: str | None = None,
              robot: str = "", gate: Path | None = None) -> None:
        role: dict[str, Any] = {}
        if near is not None:
            role = {"capabilities": ["uav"], "near": list(HOMES[near])}
        first = f"any([uav], at({HOMES[near][0]}, {HOMES[near][1]}))" if near else robot
        extra = [str(gate)] if gate is not None else []
        self.tx.send(ActionRequest(uuid=uuid, name="sweep",
                                   args=[first, f"g-{uuid}", steps, *extra],
                                   robot=robot, goal=f"g-{uuid}", role=role,
                                   literal=f"sweep({first}, g_{uuid}, {steps})"))

    def step(self, uuid: str) -> int:
        with sqlite3.connect(str(self.journal())) as db:
            row = db.execute("SELECT progress FROM actions WHERE uuid=?", (uuid,)).fetchone()
        return int(json.loads(row[0]).get("step", 0)) if row else 0


@pytest.fixture()
def system(procs: Procs, run_dir: Path) -> Iterator[System]:
    s = System(procs, run_dir)
    try:
        yield s
    finally:
        s.close()


@pytest.mark.slow
def test_a_lost_robots_task_goes_to_another_that_goes_on_from_its_progress(
        system: System) -> None:
    system.sweep("t1", steps=40, near="uav1")
    wait_until(lambda: bool(system.awards("t1")), timeout=20, message="t1 awarded")
    assert system.awards("t1")[0].robot == "uav1"  # the nearer
    wait_until(lambda: system.step("t1") >= 3, timeout=20, message="uav1 swept 3 strips")

    kill(system.sup, "uav1", signal.SIGSTOP)  # uav1's link hears nothing more
    try:
        wait_until(lambda: len(system.awards("t1")) > 1, timeout=30,
                   message="t1 awarded again")
        again = system.awards("t1")[1]
        assert again.robot == "uav2" and again.why.startswith("reassigned from uav1 (lost)")
        assert again.lost_from == "uav1" and system.awards("t1")[0].lost_from == ""
        assert [b["robot"] for b in again.bids] == ["uav2", "uav1"]
        assert again.bids[1]["unfit"] == "unavailable"  # the lost one, still away
        percept = f"reassigned(sweep(any([uav], at({HOMES['uav1'][0]}, {HOMES['uav1'][1]})), " \
                  f"g_t1, 40), uav1, uav2)"  # after the award: the agent's event
        wait_until(lambda: percept in [p.literal for p in system.bodies(Percept)],
                   timeout=20, message="the reassigned percept")
        done = system.ended("t1")
        assert (done.state, done.robot) == (ActionState.SUCCEEDED, "uav2")
        states = [(s.state, s.robot) for s in system.statuses("t1")]
        assert (ActionState.FAILED, "uav1") not in states  # the agent never saw it fail
        gone = next(s for s in system.statuses("t1") if s.state is ActionState.PENDING
                    and not s.robot)
        assert gone.reason.startswith("reassigning: robot uav1 unreachable")
        kept = int(gone.progress["step"])  # type: ignore[arg-type]
        assert kept >= 3  # where uav1 stopped ...
        resumed = next(s for s in system.statuses("t1") if s.progress.get("by") == "uav2")
        assert resumed.progress["first"] == kept  # ... uav2 went on from there
    finally:
        kill(system.sup, "uav1", signal.SIGCONT)
    # uav1 is back: available, and holding nothing of t1
    wait_until(lambda: system.available("uav1"), timeout=30, message="uav1 back")
    system.sweep("t2", steps=2, near="uav1")
    assert system.ended("t2").robot == "uav1"
    after = system.statuses("t1")[-1]
    assert (after.state, after.robot) == (ActionState.SUCCEEDED, "uav2")
    with sqlite3.connect(str(system.journal())) as db:
        assert db.execute("SELECT robot FROM actions WHERE uuid='t1'").fetchone() == ("uav2",)
        assert db.execute("SELECT COUNT(*) FROM tasks").fetchone() == (0,)  # all closed


@pytest.mark.slow
def test_decommission_hands_role_tasks_to_others_and_fails_named_ones(
        system: System) -> None:
    system.sweep("role", steps=40, near="uav2")
    # awarded before the named sweep is sent: sent at once, the named sweep could reach
    # uav2 first and make it busy, and the role task rightly go to idle uav1
    wait_until(lambda: bool(system.awards("role")), timeout=20, message="role awarded")
    assert system.awards("role")[0].robot == "uav2"
    system.sweep("named", steps=40, robot="uav2")
    wait_until(lambda: system.step("role") >= 2 and system.step("named") >= 1, timeout=20,
               message="both sweeps under way on uav2")
    system.pub.publish(Command(command="decommission", target="uav2"))
    named = system.ended("named")
    assert (named.state, named.cause) == (ActionState.FAILED, FailureCause.DECOMMISSIONED)
    wait_until(lambda: len(system.awards("role")) > 1, timeout=20, message="role re-awarded")
    assert system.awards("role")[1].robot == "uav1"
    system.pub.publish(Command(command="recommission", target="uav2"))
    wait_until(lambda: system.available("uav2"), timeout=20, message="uav2 back in service")
    done = system.ended("role")
    assert (done.state, done.robot) == (ActionState.SUCCEEDED, "uav1")
    assert int(done.progress["first"]) >= 2  # type: ignore[arg-type]


@pytest.mark.slow
def test_an_rcl_killed_between_award_and_skill_start_keeps_one_holder_per_task(
        system: System) -> None:
    gate = system.run_dir / "gate"
    system.sweep("k1", steps=3, near="uav1", gate=gate)  # its skill waits at the gate
    wait_until(lambda: bool(system.awards("k1")), timeout=20, message="k1 awarded")
    assert system.awards("k1")[0].robot == "uav1"
    system.pub.publish(Command(command="decommission", target="uav2"))
    wait_until(lambda: not system.available("uav2"), timeout=20, message="uav2 out")
    system.sweep("k2", steps=3, near="uav2")  # uav1 busy, uav2 out of service: it waits
    wait_until(lambda: any(a.state is AllocationState.WAITING
                           for a in system.bodies(TaskAllocation, uuid="k2")),
               timeout=20, message="k2 waits")
    with sqlite3.connect(str(system.journal())) as db:
        tasks = dict(db.execute("SELECT uuid, robot FROM tasks").fetchall())
    assert tasks == {"k1": "uav1", "k2": ""}  # the award journaled, the waiting task too
    assert "first" not in system.statuses("k1")[-1].progress  # the skill has not started

    kill(system.sup, "rcl")  # SIGKILL; the root supervisor restarts it
    wait_until(lambda: any(e.inc == 2 for e in list(system.seen)), timeout=30,
               message="the restarted RCL speaks")
    gate.touch()
    k1, k2 = system.ended("k1"), system.ended("k2")
    # the decommission is journaled: uav2 stays out after the restart, so k2 (nearer
    # uav2) waits for uav1 to finish k1
    assert any(e.inc == 2 and isinstance(e.body, RobotState) and e.body.robot == "uav2"
               and not e.body.available for e in list(system.seen))
    assert (k1.state, k1.robot, k1.progress["by"]) == (ActionState.SUCCEEDED, "uav1", "uav1")
    assert (k2.state, k2.robot) == (ActionState.SUCCEEDED, "uav1")
    assert [a.robot for a in system.awards("k1")] == ["uav1"]  # never awarded twice
    assert [a.robot for a in system.awards("k2")] == ["uav1"]
    for uuid in ("k1", "k2"):  # one holder: every status names the same robot (or none)
        assert {s.robot for s in system.statuses(uuid)} - {""} == {"uav1"}
    with sqlite3.connect(str(system.journal())) as db:
        assert db.execute("SELECT COUNT(*) FROM tasks").fetchone() == (0,)


@pytest.mark.slow
def test_an_rcl_killed_between_a_robots_loss_and_the_reaward_keeps_one_holder(
        system: System) -> None:
    system.pub.publish(Command(command="decommission", target="uav2"))
    wait_until(lambda: not system.available("uav2"), timeout=20, message="uav2 out")
    system.sweep("l1", steps=40, near="uav1")
    assert system.awarded("l1").robot == "uav1"
    wait_until(lambda: system.step("l1") >= 2, timeout=20, message="uav1 swept 2 strips")
    # uav1 lost too (the operator's decommission, a loss that outlives the restart):
    # no robot can take l1, it waits
    system.pub.publish(Command(command="decommission", target="uav1"))
    wait_until(lambda: any(s.state is ActionState.PENDING and not s.robot
                           for s in system.statuses("l1")), timeout=30,
               message="l1 given back by uav1")
    with sqlite3.connect(str(system.journal())) as db:
        assert db.execute("SELECT robot, lost FROM tasks").fetchall() == [("", '["uav1"]')]
    kept = system.step("l1")

    kill(system.sup, "rcl")  # SIGKILL between the loss and the re-award
    wait_until(lambda: any(e.inc == 2 for e in list(system.seen)), timeout=30,
               message="the restarted RCL speaks")
    system.pub.publish(Command(command="recommission", target="uav2"))
    done = system.ended("l1", timeout=60)
    assert (done.state, done.robot) == (ActionState.SUCCEEDED, "uav2")
    assert [a.robot for a in system.awards("l1")] == ["uav1", "uav2"]  # once each
    assert system.awards("l1")[1].why.startswith("reassigned from uav1 (lost)")
    resumed = next(s for s in system.statuses("l1") if s.progress.get("by") == "uav2")
    assert resumed.progress["first"] == kept  # from where uav1 stopped
    holders = [s.robot for s in system.statuses("l1")]  # never two: a change goes via ""
    changes = [(a, b) for a, b in zip(holders, holders[1:], strict=False) if a != b]
    assert all("" in pair for pair in changes), changes
    with sqlite3.connect(str(system.journal())) as db:
        assert db.execute("SELECT robot FROM actions WHERE uuid='l1'").fetchone() == ("uav2",)
        assert db.execute("SELECT COUNT(*) FROM tasks").fetchone() == (0,)


@pytest.mark.slow
def test_a_robot_that_does_not_come_back_after_an_rcl_restart_is_given_no_task(
        system: System) -> None:
    def states(inc: int) -> list[RobotState]:
        return [e.body for e in list(system.seen) if e.src == "rcl" and e.inc == inc
                and isinstance(e.body, RobotState) and e.body.robot == "uav2"]

    kill(system.sup, "uav2", signal.SIGSTOP)  # uav2's robot falls silent ...
    try:
        wait_until(lambda: not system.available("uav2"), timeout=30, message="uav2 lost")
        kill(system.sup, "rcl")  # ... and the RCL restarts without ever hearing it again
        wait_until(lambda: bool(states(2)), timeout=30,
                   message="the restarted RCL announces uav2")
        # its link starts down and never reports: uav2 is unavailable from the start
        assert states(2)[0].reason == "link down: waiting for its link's first report"
        system.sweep("n1", steps=2, near="uav2")  # uav2 is the nearer, but silent
        done = system.ended("n1")
        assert (done.state, done.robot) == (ActionState.SUCCEEDED, "uav1")
        assert [a.robot for a in system.awards("n1")] == ["uav1"]
        wait_until(lambda: any(s.reason.startswith("link down: no first report within 3 s")
                               for s in states(2)), timeout=30,
                   message="uav2 given up past its link's timeout")
        assert not any(s.available for s in states(2))
    finally:
        kill(system.sup, "uav2", signal.SIGCONT)
    wait_until(lambda: system.available("uav2"), timeout=30, message="uav2 back")
