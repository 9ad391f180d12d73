"""Tasks addressed to a role, through real processes: a bus proxy and the RCL component
under the root supervisor, with several simulated robots (fakes of the physical robots
standing where their tables say). The test plays the reasoner: it sends role-addressed
`ActionRequest`s on the reliable action channel and watches `action.allocation` and
`action.status` on the bus."""

from __future__ import annotations

from collections.abc import Iterator
from pathlib import Path
from typing import Any

import pytest

from mrss.messages import (
    ActionControl,
    ActionRequest,
    ActionState,
    AllocationState,
    Command,
    ControlCommand,
    ControlTarget,
    RobotState,
    WaitReason,
)
from mrss.testing import wait_until
from tests.actors.rcl.processes import Bus, Procs, rcl_child, root

PROJECT = Path(__file__).parent / "allocation_project"
ROBOTS: dict[str, dict[str, Any]] = {
    # two ground robots with cameras, 1.1 km apart; one UAV, low on battery
    "ugv1": {"at": [48.00, 16.00], "capabilities": ["ugv", "camera"]},
    "ugv2": {"at": [48.01, 16.00], "capabilities": ["ugv", "camera"]},
    "uav1": {"at": [48.00, 16.00], "capabilities": ["uav", "camera"], "battery": 60.0},
}


class Rcl(Bus):
    """The RCL process on its bus, and what the test heard."""

    def __init__(self, procs: Procs, run_dir: Path) -> None:
        super().__init__(procs, run_dir, ["action.", "robot."])
        self.sup = root(PROJECT, run_dir, self.endpoints,
                        [rcl_child({"robots": ROBOTS, "heartbeat": 0.2})])
        self.sup.start()
        assert self.sup.wait_started(30), "the RCL component did not start"

    def close(self) -> None:
        self.sup.stop(timeout=30)
        super().close()

    def request(self, uuid: str, caps: list[str], near: list[float] | None = None,
                seconds: float = 0.2, priority: int = 0) -> None:
        role: dict[str, Any] = {"capabilities": caps}
        if near is not None:
            role["near"] = near
        self.tx.send(ActionRequest(uuid=uuid, name="survey", args=["any", f"g-{uuid}",
                                                                     seconds],
                                   goal=f"g-{uuid}", priority=priority, role=role))


@pytest.fixture()
def rcl(procs: Procs, run_dir: Path) -> Iterator[Rcl]:
    r = Rcl(procs, run_dir)
    try:
        yield r
    finally:
        r.close()


@pytest.mark.slow
def test_a_task_goes_to_the_robot_that_finishes_it_first(rcl: Rcl) -> None:
    rcl.request("near-ugv2", ["ugv", "camera"], near=[48.0095, 16.0])
    award = rcl.awarded("near-ugv2")
    assert award.robot == "ugv2"
    assert award.why.startswith("ugv2: finish in ") and "ugv1: finish in" in award.why
    # the same decision, structured: every capable robot's bid in rank order
    assert [b["robot"] for b in award.bids] == ["ugv2", "ugv1"]
    assert award.bids[0]["unfit"] == "" and award.bids[0]["reserve"] == 20.0
    assert award.bids[0]["finish_s"] < award.bids[1]["finish_s"]
    assert (award.evaluator, award.capabilities, award.near, award.bidders) == \
        ("quickest_finish", ["camera", "ugv"], [48.0095, 16.0], 2)
    done = rcl.ended("near-ugv2")
    assert (done.state, done.robot) == (ActionState.SUCCEEDED, "ugv2")
    rcl.request("near-ugv1", ["camera"], near=[48.0005, 16.0])  # uav1 stands there too:
    first = rcl.awarded("near-ugv1")  # equally quick: the robot id breaks the tie
    assert first.robot == "uav1" and "ugv1: finish in 11 s" in first.why
    rcl.ended("near-ugv1")
    rcl.request("again", ["camera"], near=[48.0005, 16.0])
    assert rcl.awarded("again").robot == "uav1"  # the same tie, the same robot


@pytest.mark.slow
def test_a_task_waits_while_every_capable_robot_is_busy_then_is_awarded(rcl: Rcl) -> None:
    rcl.request("long", ["uav"], seconds=600)
    assert rcl.awarded("long").robot == "uav1"
    wait_until(lambda: any(s.state is ActionState.RUNNING for s in rcl.statuses("long")),
               timeout=20, message="the long survey runs")
    rcl.request("next", ["uav"], seconds=0.1)
    wait_until(lambda: any(a.state is AllocationState.WAITING for a in rcl.allocations("next")),
               timeout=20, message="the next task waits")
    waiting = rcl.allocations("next")[0]
    assert waiting.wait is WaitReason.BUSY and "uav1 busy with priority 0" in waiting.why
    assert [(b["robot"], b["unfit"], b["busy_priority"]) for b in waiting.bids] == \
        [("uav1", "busy", 0)]
    assert not rcl.statuses("next")  # no robot has it yet
    rcl.tx.send(ActionControl(command=ControlCommand.CANCEL, target="long",
                              target_kind=ControlTarget.ACTION))
    assert rcl.awarded("next").robot == "uav1"
    assert rcl.ended("long").state is ActionState.CANCELLED
    assert rcl.ended("next").state is ActionState.SUCCEEDED


@pytest.mark.slow
def test_a_higher_priority_task_preempts_and_a_low_battery_robot_is_passed_over(
        rcl: Rcl) -> None:
    rcl.request("low", ["uav"], seconds=600, priority=1)
    assert rcl.awarded("low").robot == "uav1"
    rcl.request("urgent", ["uav"], seconds=0.1, priority=5)
    award = rcl.awarded("urgent")
    assert award.robot == "uav1" and "pre-empting priority 1" in award.why
    assert rcl.ended("urgent").state is ActionState.SUCCEEDED
    wait_until(lambda: any(s.state is ActionState.SUSPENDED for s in rcl.statuses("low")),
               timeout=20, message="the low-priority survey suspended")
    # uav1 has 60 %: 30 km away and back costs more than it may spend above its reserve
    # (priority 9 would pre-empt anything: the battery is what stops it)
    rcl.request("far", ["uav"], near=[48.30, 16.0], priority=9)
    wait_until(lambda: any(a.state is AllocationState.WAITING for a in rcl.allocations("far")),
               timeout=20, message="the far task waits")
    far = rcl.allocations("far")[0]
    assert far.wait is WaitReason.BATTERY and "below its reserve 20 %" in far.why
    (bid,) = far.bids
    assert (bid["unfit"], bid["reserve"]) == ("battery", 20.0) and bid["battery_after"] < 20


@pytest.mark.slow
def test_a_robot_put_in_teleop_gets_no_task_until_it_is_out_of_teleop(rcl: Rcl) -> None:
    def teleop(on: bool) -> None:  # told, and the RCL says so (its actor may not have yet)
        since = len(rcl.seen)
        rcl.pub.publish(Command(command="teleop", target="uav1", args={"on": on}))
        wait_until(lambda: any(isinstance(e.body, RobotState) and e.body.robot == "uav1"
                               and e.body.attributes.get("teleop") is on
                               for e in rcl.seen[since:]),
                   timeout=20, message=f"uav1's teleop {on}")

    teleop(True)
    rcl.request("flight", ["uav"], seconds=0.1)
    wait_until(lambda: any(a.state is AllocationState.WAITING
                           for a in rcl.allocations("flight")),
               timeout=20, message="the task waits for the only UAV")
    waiting = rcl.allocations("flight")[0]
    assert waiting.wait is WaitReason.UNAVAILABLE and "uav1 in teleop" in waiting.why
    assert not rcl.statuses("flight")
    teleop(False)
    assert rcl.awarded("flight").robot == "uav1"
    assert rcl.ended("flight").state is ActionState.SUCCEEDED


@pytest.mark.slow
def test_a_role_no_robot_has_is_rejected_with_a_did_you_mean(rcl: Rcl) -> None:
    rcl.request("typo", ["camra"])
    done = rcl.ended("typo")
    assert done.state is ActionState.FAILED
    assert "no configured robot has camra" in done.reason and "did you mean 'camera'" in \
        done.reason
