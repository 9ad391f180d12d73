"""The project API: state tables, the default action conventions, skills outside an RCL."""

from __future__ import annotations

import pytest

from mrss.api import (
    ACTION_TRANSITIONS,
    SKILL_TRANSITIONS,
    Action,
    ActionState,
    Resource,
    RobotCommLayer,
    Skill,
    SkillOutcome,
    SkillState,
)
from mrss.errors import ActionError
from mrss.messages import ActionRequest

S = ActionState


@pytest.mark.parametrize(("path", "legal"), [
    ([S.PENDING, S.RUNNING, S.SUCCEEDED], True),
    ([S.PENDING, S.RUNNING, S.SUSPENDED, S.RUNNING, S.FAILED], True),
    ([S.PENDING, S.SUSPENDED, S.RUNNING, S.CANCELLED], True),
    ([S.PENDING, S.RUNNING, S.SUSPENDED, S.SUCCEEDED], True),
    ([S.PENDING, S.RUNNING, S.RUNNING], False),
    ([S.PENDING, S.RUNNING, S.PENDING], False),
    ([S.PENDING, S.SUCCEEDED, S.RUNNING], False),
    ([S.PENDING, S.CANCELLED, S.FAILED], False),
])
def test_action_transitions_follow_the_table(path: list[ActionState], legal: bool) -> None:
    action = Action(uuid="u1", name="cover")
    assert action.state is path[0]
    if legal:
        for state in path[1:]:
            action.transition(state, "why")
        assert action.state is path[-1] and action.reason == "why"
    else:
        with pytest.raises(ActionError) as info:
            for state in path[1:]:
                action.transition(state)
        assert info.value.uuid == "u1" and "illegal transition" in info.value.reason


def test_terminal_states_lead_nowhere_and_the_table_covers_every_state() -> None:
    assert set(ACTION_TRANSITIONS) == set(ActionState)
    assert set(SKILL_TRANSITIONS) == set(SkillState)
    for state in ActionState:
        assert (ACTION_TRANSITIONS[state] == frozenset()) == state.terminal


def test_action_copy_is_independent() -> None:
    action = Action(uuid="u", name="n", args=["r", "g"], progress={"waypoint": 1})
    snap = action.copy()
    snap.progress["waypoint"] = 2
    snap.args.append("x")
    assert action.progress == {"waypoint": 1} and action.args == ["r", "g"]


def test_default_action_cb_reads_robot_and_goal_from_the_arguments() -> None:
    layer = RobotCommLayer()
    action = layer.action_cb(ActionRequest(uuid="u", name="cover", args=["uav1", "area7", 3],
                                           priority=4, literal="cover(uav1,area7,3)"))
    assert (action.robot, action.goal, action.priority, action.args) == (
        "uav1", "area7", 4, ["uav1", "area7", 3])
    assert action.state is ActionState.PENDING
    numeric_goal = layer.action_cb(ActionRequest(uuid="u", name="cover", args=["uav1", 12]))
    assert numeric_goal.goal == "12"
    explicit = layer.action_cb(ActionRequest(uuid="u", name="cover", args=[1, 2],
                                             robot="ugv1", goal="g"))
    assert (explicit.robot, explicit.goal) == ("ugv1", "g")


@pytest.mark.parametrize("args", [[], [3, "g"], [["uav1"], "g"], [""]])
def test_default_action_cb_rejects_actions_without_a_robot(args: list[object]) -> None:
    with pytest.raises(ActionError, match="no robot id"):
        RobotCommLayer().action_cb(ActionRequest(uuid="u", name="cover", args=args))


def test_default_check_action_status_is_a_logical_and() -> None:
    check = RobotCommLayer().check_action_status
    a = Action(uuid="u", name="n")
    ok, ko, intr = SkillOutcome.SUCCEEDED, SkillOutcome.FAILED, SkillOutcome.INTERRUPTED
    assert check(a, [ok, ok]) is S.SUCCEEDED
    assert check(a, [ok, None]) is None
    assert check(a, [ko, None]) is S.FAILED
    assert check(a, [intr, ok]) is S.FAILED
    assert check(a, []) is S.SUCCEEDED


def test_default_refine_action_has_no_recipes() -> None:
    with pytest.raises(ActionError, match="no recipe"):
        RobotCommLayer().refine_action(Action(uuid="u", name="cover"))


def test_skill_outside_an_rcl_says_so() -> None:
    class Idle(Skill):
        def run(self) -> None:
            pass

    skill = Idle()
    assert skill.state is SkillState.START and skill.name == "Idle"
    with pytest.raises(ActionError, match="not running under an RCL"):
        _ = skill.link
    with pytest.raises(ActionError, match="not running under an RCL"):
        skill.acquire("airspace")


def test_skill_states_follow_the_table() -> None:
    class Idle(Skill):
        pass

    skill = Idle()
    skill._set_state(SkillState.RUN)
    skill._set_state(SkillState.INTERRUPT)
    with pytest.raises(ActionError, match="illegal transition"):
        skill._set_state(SkillState.RUN)
    skill._set_state(SkillState.FINISH)
    skill._set_state(SkillState.START)  # a restart


def test_resource_names() -> None:
    assert Resource("motion", per_robot=True).qualified("ugv1") == "ugv1/motion"
    assert Resource("airspace").qualified("ugv1") == "airspace"
