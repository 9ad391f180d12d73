"""The RCL's failsafe hook: a failsafe ends the robot's actions with its own reason, and a
link heartbeats its robot only while a live robot actor controls it."""

from __future__ import annotations

from collections.abc import Callable, Iterator
from pathlib import Path

import pytest

from mrss.links.failsafe import failsafe_reason
from mrss.messages import FailureCause, RobotState
from mrss.testing import wait_until
from tests.actors.rcl_sim import RclEnv, SimRobot, request_fields


class WatchedRobot(SimRobot):
    """A simulated robot whose "link" takes the RCL's controller check, as RobotLink does."""

    def __init__(self, name: str) -> None:
        super().__init__(name)
        self.controller: Callable[[], bool] | None = None

    def watch_controller(self, check: Callable[[], bool]) -> None:
        self.controller = check


@pytest.fixture()
def env(tmp_path: Path) -> Iterator[tuple[RclEnv, WatchedRobot]]:
    robot = WatchedRobot("uav1")
    rcl = RclEnv(tmp_path / "journal.sqlite3", {"uav1": robot, "ugv1": SimRobot("ugv1")})
    try:
        yield rcl, robot
    finally:
        for r in rcl.robots.values():
            r.halt()
        rcl.stop()


def test_failsafe_fails_running_actions_with_the_failsafe_reason(
        env: tuple[RclEnv, WatchedRobot]) -> None:
    rcl, _ = env
    core = rcl.start()
    core.submit_fields(request_fields("a1", "patrol", "uav1", "g1", ["p1", "p2"]))
    wait_until(rcl.statuses.reached("a1", "running"))
    why = failsafe_reason("uav1 lost its controller and took its failsafe (vehicle: "
                          "'GCS Failsafe')")
    assert core.availability.link_state("uav1", False, why) == ["a1"]
    core.availability.link_state("uav1", True,
                                 "control regained after a failsafe; vehicle in BRAKE")
    wait_until(rcl.statuses.reached("a1", "failed"))
    last = rcl.statuses.last("a1")
    assert last is not None and last.reason == why
    assert last.cause == FailureCause.FAILSAFE  # the agent matches error(failsafe)
    states = [m for m in rcl.statuses.others if isinstance(m, RobotState)]
    assert any(s.reason == f"link down: {why}" and s.link == "down" for s in states)
    assert states[-1].available  # control is back: new actions are taken
    core.submit_fields(request_fields("a2", "patrol", "uav1", "g2", ["p1"]))
    wait_until(rcl.statuses.reached("a2", "running"))


def test_link_heartbeats_only_while_a_robot_actor_controls_the_robot(
        env: tuple[RclEnv, WatchedRobot]) -> None:
    rcl, robot = env
    core = rcl.start()
    check = robot.controller
    assert check is not None and check()
    assert core.controls("uav1") and core.controls("ugv1")
    rcl.stop()  # every robot actor is gone
    assert not check()
