"""Goal management (cancel/suspend/resume/succeed/fail) and teleop on a running RCL."""

from __future__ import annotations

from mrss.actors.rcl.core import RclCore
from mrss.messages import ActionControl, ActionStatus, RobotState
from mrss.testing import wait_until
from tests.actors.rcl_sim import RclEnv, request_fields


def _patrol(rcl_env: RclEnv, core: RclCore, uuid: str, robot: str = "ugv1",
            goal: str = "g1", waypoints: tuple[str, ...] = ("p1", "p2", "p3", "p4")) -> None:
    core.submit_fields(request_fields(uuid, "patrol", robot, goal, list(waypoints)))
    wait_until(rcl_env.statuses.reached(uuid, "running"))


def test_suspend_keeps_progress_and_resume_continues_from_it(rcl_env: RclEnv) -> None:
    core = rcl_env.start()
    robot = rcl_env.robots["ugv1"]
    _patrol(rcl_env, core, "a1")
    robot.arrive(2)
    wait_until(lambda: robot.is_moving_to("p3"), message="ugv1 heading to p3")
    assert core.control(ActionControl("suspend", "a1")) == ["a1"]
    wait_until(rcl_env.statuses.reached("a1", "suspended"))
    suspended = rcl_env.statuses.last("a1")
    assert suspended is not None and suspended.progress == {"waypoint": 2}
    assert robot.halts == 1 and robot.visited == ["p1", "p2"]

    core.control(ActionControl("resume", "a1"))
    wait_until(rcl_env.statuses.reached("a1", "running"))
    wait_until(lambda: robot.is_moving_to("p3"), message="resumed at p3, not p1")
    assert rcl_env.layer.refined[-1].progress == {"waypoint": 2}
    robot.arrive(2)
    wait_until(rcl_env.statuses.reached("a1", "succeeded"))
    assert robot.visited == ["p1", "p2", "p3", "p4"]
    assert rcl_env.statuses.states("a1") == [
        "pending", "running", "suspended", "running", "succeeded"]


def test_cancel_stops_the_robot_and_ends_the_action(rcl_env: RclEnv) -> None:
    core = rcl_env.start()
    robot = rcl_env.robots["ugv1"]
    _patrol(rcl_env, core, "a1")
    wait_until(lambda: robot.is_moving_to("p1"))
    core.control(ActionControl("cancel", "a1"))
    wait_until(rcl_env.statuses.reached("a1", "cancelled"))
    assert robot.halts == 1 and robot.visited == []
    assert rcl_env.layer.ended[-1].uuid == "a1"
    assert core.observers.active() == {}


def test_succeed_and_fail_commands_end_actions_directly(rcl_env: RclEnv) -> None:
    core = rcl_env.start()
    _patrol(rcl_env, core, "a1", robot="ugv1")
    _patrol(rcl_env, core, "a2", robot="uav1")
    core.control(ActionControl("succeed", "a1"))
    core.control(ActionControl("fail", "a2"))
    wait_until(rcl_env.statuses.reached("a1", "succeeded"))
    wait_until(rcl_env.statuses.reached("a2", "failed"))
    last = rcl_env.statuses.last("a2")
    assert last is not None and "failed by the operator" in last.reason


def test_cancel_of_a_suspended_action(rcl_env: RclEnv) -> None:
    core = rcl_env.start()
    _patrol(rcl_env, core, "a1")
    core.control(ActionControl("suspend", "a1"))
    wait_until(rcl_env.statuses.reached("a1", "suspended"))
    core.control(ActionControl("cancel", "a1"))
    wait_until(rcl_env.statuses.reached("a1", "cancelled"))


def test_goal_and_robot_targets_reach_every_matching_action(rcl_env: RclEnv) -> None:
    core = rcl_env.start()
    _patrol(rcl_env, core, "a1", robot="ugv1", goal="area")
    _patrol(rcl_env, core, "a2", robot="uav1", goal="area")
    _patrol(rcl_env, core, "a3", robot="ugv2", goal="other")
    assert sorted(core.control(ActionControl("suspend", "area", "goal"))) == ["a1", "a2"]
    wait_until(rcl_env.statuses.reached("a1", "suspended"))
    wait_until(rcl_env.statuses.reached("a2", "suspended"))
    assert core.observers.active()["a3"].value == "running"
    assert core.control(ActionControl("cancel", "ugv2", "robot")) == ["a3"]
    wait_until(rcl_env.statuses.reached("a3", "cancelled"))
    assert sorted(core.observers.active()) == ["a1", "a2"]


def test_control_for_an_unknown_target_changes_nothing(rcl_env: RclEnv) -> None:
    core = rcl_env.start()
    _patrol(rcl_env, core, "a1")
    assert core.control(ActionControl("cancel", "nope")) == []
    assert core.control(ActionControl("cancel", "ugv9", "robot")) == []
    assert core.observers.active()["a1"].value == "running"


def test_teleop_suspends_every_action_and_resumes_them_from_progress(rcl_env: RclEnv) -> None:
    core = rcl_env.start()
    robot = rcl_env.robots["ugv1"]
    _patrol(rcl_env, core, "a1", waypoints=("p1", "p2", "p3"))
    robot.arrive(1)
    wait_until(lambda: robot.is_moving_to("p2"))
    core.availability.set_teleop("ugv1", True)
    wait_until(rcl_env.statuses.reached("a1", "suspended"))
    # a resume from the reasoner does not override the operator's teleop
    core.control(ActionControl("resume", "a1"))
    # an action that arrives during teleop waits suspended (handled after the resume)
    core.submit_fields(request_fields("a2", "noop", "ugv1", "g2"))
    wait_until(rcl_env.statuses.reached("a2", "suspended"))
    assert rcl_env.statuses.states("a1") == ["pending", "running", "suspended"]

    core.availability.set_teleop("ugv1", False)
    wait_until(rcl_env.statuses.reached("a2", "succeeded"))
    wait_until(lambda: robot.is_moving_to("p2"), message="a1 resumed at p2")
    robot.arrive(2)
    wait_until(rcl_env.statuses.reached("a1", "succeeded"))
    assert robot.visited == ["p1", "p2", "p3"]
    teleop_flags = [m.attributes.get("teleop") for m in rcl_env.statuses.others
                    if getattr(m, "robot", "") == "ugv1"]
    assert teleop_flags == [False, True, False]  # announced at start, then on, off


def test_teleop_does_not_resume_an_action_suspended_by_goal_management(
    rcl_env: RclEnv,
) -> None:
    core = rcl_env.start()
    _patrol(rcl_env, core, "a1")
    core.control(ActionControl("suspend", "a1"))
    wait_until(rcl_env.statuses.reached("a1", "suspended"))
    core.availability.set_teleop("ugv1", True)
    core.availability.set_teleop("ugv1", False)
    core.submit_fields(request_fields("a2", "noop", "ugv1", "g2"))  # flushes the inbox
    wait_until(rcl_env.statuses.reached("a2", "succeeded"))
    assert {u: s.value for u, s in core.observers.active().items()} == {"a1": "suspended"}


def test_skill_ignoring_its_interrupt_is_abandoned(rcl_env: RclEnv) -> None:
    import threading

    from tests.actors.rcl_sim import Stubborn

    release = threading.Event()
    rcl_env.layer.interrupt_timeout = 0.3
    rcl_env.layer.recipes["stubborn"] = lambda a: [Stubborn(release)]
    core = rcl_env.start()
    try:
        core.submit_fields(request_fields("s1", "stubborn", "ugv1", "g1"))
        wait_until(rcl_env.statuses.reached("s1", "running"))
        core.control(ActionControl("cancel", "s1"))
        wait_until(rcl_env.statuses.reached("s1", "cancelled"))
    finally:
        release.set()


def test_link_down_fails_the_robots_actions_and_marks_it_unavailable(rcl_env: RclEnv) -> None:
    core = rcl_env.start()
    _patrol(rcl_env, core, "a1", robot="ugv1")
    _patrol(rcl_env, core, "a2", robot="uav1")
    assert core.availability.link_state("ugv1", False, "no heartbeat for 3.0 s") == ["a1"]
    wait_until(rcl_env.statuses.reached("a1", "failed"))
    last = rcl_env.statuses.last("a1")
    assert last is not None and last.reason == "robot ugv1 unreachable: no heartbeat for 3.0 s"
    assert rcl_env.statuses.states("a2") == ["pending", "running"]  # other robots go on
    states = [m for m in rcl_env.statuses.others if isinstance(m, RobotState)]
    assert states[-1].robot == "ugv1" and not states[-1].available
    assert states[-1].reason == "link down: no heartbeat for 3.0 s"
    assert states[-1].link == "down"
    # an action for the unreachable robot is refused with the reason
    core.submit_fields(request_fields("a3", "patrol", "ugv1", "g3", ["p1"]))
    wait_until(rcl_env.statuses.reached("a3", "failed"))
    assert "link down: no heartbeat" in (rcl_env.statuses.last("a3") or ActionStatus(
        uuid="x", state="failed")).reason

    core.availability.link_state("ugv1", True)
    wait_until(lambda: [m for m in rcl_env.statuses.others
                        if isinstance(m, RobotState)][-1].available, message="ugv1 back")
    core.submit_fields(request_fields("a4", "patrol", "ugv1", "g4", ["p1"]))
    wait_until(rcl_env.statuses.reached("a4", "running"))


def test_every_robot_state_is_announced_when_the_rcl_starts(rcl_env: RclEnv) -> None:
    rcl_env.start()
    announced = {m.robot: m for m in rcl_env.statuses.others if isinstance(m, RobotState)}
    assert sorted(announced) == ["uav1", "ugv1", "ugv2"]
    assert all(m.available and m.link == "up" and m.attributes == {"teleop": False}
               for m in announced.values())


def test_a_goal_suspended_before_its_action_is_requested_starts_it_suspended(
        rcl_env: RclEnv) -> None:
    """The agent pre-empts a goal whose action it has not requested yet: that action,
    when it comes, is held (not run) until the goal is resumed; other goals run."""
    core = rcl_env.start()
    robot = rcl_env.robots["ugv1"]
    assert core.control(ActionControl("suspend", "early", "goal")) == []  # nothing yet
    core.submit_fields(request_fields("a1", "patrol", "ugv1", "early", ["p1", "p2"]))
    wait_until(rcl_env.statuses.reached("a1", "suspended"))
    assert robot.visited == [] and not robot.is_moving_to("p1")
    last = rcl_env.statuses.last("a1")
    assert last is not None and "its goal is suspended" in last.reason
    _patrol(rcl_env, core, "a2", robot="uav1", goal="other")  # another goal runs
    core.control(ActionControl("resume", "early", "goal"))
    wait_until(rcl_env.statuses.reached("a1", "running"))
    wait_until(lambda: robot.is_moving_to("p1"), message="a1 runs once resumed")
    assert rcl_env.statuses.states("a1") == ["pending", "suspended", "running"]
    # released: the goal's next action runs at once
    core.control(ActionControl("cancel", "a1"))
    wait_until(rcl_env.statuses.reached("a1", "cancelled"))
    core.submit_fields(request_fields("a3", "patrol", "ugv1", "early", ["p1"]))
    wait_until(rcl_env.statuses.reached("a3", "running"))
