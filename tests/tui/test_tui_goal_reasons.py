"""Why, on the mission panel: queued for which robot behind which goal, an action
waiting for its robot's resource shown queued (not running) behind whom, a failed goal's
reason from its action's cause, a refusal's reason from `refused(Goal, Why)`."""

from __future__ import annotations

from mrss.config.operator import GoalState, read_operator
from mrss.messages import ActionRequest, ActionStatus
from mrss.messages.closed_sets import ActionState, FailureCause
from mrss.tui.models.actions import ActionsModel
from mrss.tui.models.alerts import AlertsModel
from mrss.tui.models.goals import GoalsModel

GOALS = {"queued": "queued(Robot, Goal, Priority, _)", "running": "task(Robot, Goal, Priority)",
         "failed": "failed_goal(Goal)", "refused": "refused(Goal, Why)"}


def test_each_goal_says_why_it_stands_where_it_does() -> None:
    goals = GoalsModel(read_operator({"goals": GOALS}).goals)
    actions = ActionsModel()
    actions.apply_request(ActionRequest(uuid="u1", name="cover", args=[], robot="uav1",
                                        goal="a1"), 1.0, "reasoner")
    actions.apply_request(ActionRequest(uuid="u0", name="survey", args=[], robot="uav1",
                                        goal="a0"), 1.0, "reasoner")
    goals.apply_beliefs(["task(uav1,a1,2)", "queued(uav1,a2,1,cover)",
                         "refused(a9,outside_the_map)"], 2.0, actions)
    by = {v.goal: v for v in goals.newest_first()}
    assert goals.reason(by["a2"], actions) == "for uav1 behind a1"
    assert by["a9"].state is GoalState.REFUSED
    assert goals.reason(by["a9"], actions) == "outside_the_map"
    # a1's action waits for the arm held by a0's: queued, not running
    actions.apply_status(ActionStatus(uuid="u1", state=ActionState.RUNNING, robot="uav1",
                                      progress={"queued_for": "arm", "behind": "u0"}), 3.0)
    assert actions.actions["u1"].shown_state == "queued"
    assert goals.reason(by["a1"], actions) == "cover queued for arm behind a0"
    actions.apply_status(ActionStatus(uuid="u1", state=ActionState.RUNNING, robot="uav1",
                                      progress={"queued_for": "", "behind": "",
                                                "leg": 1}), 4.0)
    assert actions.actions["u1"].shown_state == "running"
    assert goals.reason(by["a1"], actions) == "cover running"
    # it fails: the goal's reason is the action's, with its cause; the alert says it
    actions.apply_status(ActionStatus(uuid="u1", state=ActionState.FAILED, robot="uav1",
                                      reason="link lost", cause=FailureCause.LINK_DOWN), 5.0)
    goals.apply_beliefs(["failed_goal(a1)"], 6.0, actions)
    [ended] = [v for v in goals.take_ended() if v.goal == "a1"]
    why = goals.reason(ended, actions)
    assert why == "link lost (link_down)"
    alert = AlertsModel().goal_failed("a1", "uav1", 6.0, why)
    assert "link lost (link_down)" in alert.line()


def test_a_goal_asked_of_a_role_shows_the_robot_its_action_went_to() -> None:
    """`task(_, Goal, Priority)`: the agent asked a role, the RCL awarded the robot. The
    goal shows the robot of its newest action (none before the award, the new one after a
    reassignment), and suspended while the RCL holds that action suspended."""
    goals = GoalsModel(read_operator({"goals": {"running": "task(_, Goal, Priority)"}}).goals)
    actions = ActionsModel()
    actions.apply_request(ActionRequest(uuid="u1", name="cover", args=["any([uav])", "a1"],
                                        robot="", goal="a1"), 1.0, "reasoner")
    goals.apply_beliefs(["task(any([uav]),a1,2)"], 1.5, actions)
    [a1] = goals.newest_first()
    assert (a1.state, a1.robot, a1.priority) == (GoalState.RUNNING, "", 2)  # not awarded yet
    actions.apply_status(ActionStatus(uuid="u1", state=ActionState.RUNNING, robot="uav1"), 2.0)
    goals.apply_beliefs(["task(any([uav]),a1,2)"], 2.5, actions)
    assert (a1.state, a1.robot) == (GoalState.RUNNING, "uav1")
    actions.apply_status(ActionStatus(uuid="u1", state=ActionState.SUSPENDED, robot="uav1"),
                         3.0)
    goals.apply_beliefs(["task(any([uav]),a1,2)"], 3.5, actions)
    assert (a1.state, a1.robot) == (GoalState.SUSPENDED, "uav1")
    actions.apply_status(ActionStatus(uuid="u1", state=ActionState.RUNNING, robot="uav2"), 4.0)
    goals.apply_beliefs(["task(any([uav]),a1,2)"], 4.5, actions)
    assert (a1.state, a1.robot) == (GoalState.RUNNING, "uav2")   # handed on
