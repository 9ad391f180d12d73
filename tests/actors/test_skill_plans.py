"""A skill's robot data and planned path (`Skill.publish_data`, `Skill.publish_plan`):
they go out as the robot's data, the RCL's snapshot sends each open action's latest
plan again, and the RCL clears a plan when its action ends."""

from __future__ import annotations

from typing import Any

from mrss.api import Action, Skill
from mrss.messages import ActionControl, RobotData
from mrss.testing import wait_until
from tests.actors.rcl_sim import Patrol, RclEnv, request_fields

POINTS = [[47.0, 15.0], [47.001, 15.0], [47.001, 15.001]]


class Survey(Patrol):
    """Patrol that shows its waypoints: the plan first, again as each is reached."""

    def run(self) -> bool:
        index = int(self.progress.get("waypoint", 0))  # type: ignore[arg-type]
        self.publish_plan(self.waypoints, index)  # type: ignore[arg-type]
        self.publish_data(type="note", text="surveying")
        while index < len(self.waypoints):
            if self.interrupted or not self.link.goto(self.waypoints[index]):
                return False
            index += 1
            self.publish_plan(self.waypoints, index)  # type: ignore[arg-type]
        return True


def survey(action: Action) -> list[Skill]:
    return [Survey(list(action.args[2]))]  # type: ignore[arg-type]


def robot_data(env: RclEnv, robot: str) -> list[dict[str, Any]]:
    with env.statuses.lock:
        return [dict(m.data) for m in env.statuses.others
                if isinstance(m, RobotData) and m.robot == robot]


def plans(env: RclEnv, robot: str) -> list[tuple[str, int, int]]:
    """(action, waypoints, next) of each plan record sent for `robot`."""
    return [(d["action"], len(d["waypoints"]), d["next"]) for d in robot_data(env, robot)
            if d.get("type") == "plan"]


def test_a_plan_goes_out_as_waypoints_are_reached_and_is_cleared_when_the_action_ends(
        rcl_env: RclEnv) -> None:
    rcl_env.layer.recipes["survey"] = survey
    rcl_env.layer.bind_runtime(publish=rcl_env.statuses)
    core = rcl_env.start()
    core.submit_fields(request_fields("a1", "survey", "ugv1", "g1", POINTS))
    wait_until(lambda: plans(rcl_env, "ugv1") == [("a1", 3, 0)], message="the plan")
    first = [d for d in robot_data(rcl_env, "ugv1") if d["type"] == "plan"][0]
    assert first["waypoints"] == POINTS and first["goal"] == "g1"
    assert {"type": "note", "text": "surveying"} in robot_data(rcl_env, "ugv1")
    rcl_env.robots["ugv1"].arrive(1)
    wait_until(lambda: plans(rcl_env, "ugv1")[-1] == ("a1", 3, 1), message="one reached")
    # a dashboard that attaches late asks for a snapshot: the latest plan comes again
    core.observers.snapshot()
    assert plans(rcl_env, "ugv1") == [("a1", 3, 0), ("a1", 3, 1), ("a1", 3, 1)]
    rcl_env.robots["ugv1"].arrive(2)
    wait_until(rcl_env.statuses.reached("a1", "succeeded"), message="a1 succeeded")
    wait_until(lambda: len(plans(rcl_env, "ugv1")) == 6, message="the plan cleared")
    assert plans(rcl_env, "ugv1") == [("a1", 3, 0), ("a1", 3, 1), ("a1", 3, 1), ("a1", 3, 2),
                                      ("a1", 3, 3), ("a1", 0, 0)]
    core.observers.snapshot()  # ended: its plan is not sent again
    assert len(plans(rcl_env, "ugv1")) == 6
    # an action whose skills publish no plan sends no clearing record
    rcl_env.robots["ugv2"].auto = True
    core.submit_fields(request_fields("a2", "patrol", "ugv2", "g2", ["p1"]))
    wait_until(rcl_env.statuses.reached("a2", "succeeded"), message="a2 succeeded")
    assert plans(rcl_env, "ugv2") == []


def test_a_cancelled_action_clears_its_plan(rcl_env: RclEnv) -> None:
    rcl_env.layer.recipes["survey"] = survey
    rcl_env.layer.bind_runtime(publish=rcl_env.statuses)
    core = rcl_env.start()
    core.submit_fields(request_fields("a1", "survey", "uav1", "g1", POINTS))
    wait_until(lambda: plans(rcl_env, "uav1") == [("a1", 3, 0)], message="the plan")
    core.control(ActionControl("cancel", "a1"))
    wait_until(rcl_env.statuses.reached("a1", "cancelled"), message="a1 cancelled")
    wait_until(lambda: plans(rcl_env, "uav1")[-1:] == [("a1", 0, 0)],
               message="the plan cleared")
