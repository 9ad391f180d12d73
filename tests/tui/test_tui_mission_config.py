"""`[operator]` read and checked; the goals model from belief patterns (no system)."""

from __future__ import annotations

import shutil
from pathlib import Path

import pytest

from mrss.bus import BusEndpoints
from mrss.check import check_project
from mrss.config.loader import load_file
from mrss.config.operator import (
    GoalState,
    OperatorCommand,
    PayloadError,
    area_payload,
    read_operator,
)
from mrss.errors import ConfigError
from mrss.tui.app import MrssApp
from mrss.tui.confirm import ConfirmScreen
from mrss.tui.mission import MissionChannel
from mrss.tui.models.goals import GoalsModel
from mrss.tui.widgets.operator_bar import OperatorBar
from tests.tui.conftest import HERE
from tests.tui.tui_helpers import run, until

GOALS = {"queued": "queued(Robot, Goal, Priority, _)", "running": "task(Robot, Goal, Priority)",
         "suspended": "waiting(Robot, Goal, Priority)", "failed": "failed_goal(Goal)"}


def test_operator_table_is_read_and_its_mistakes_named() -> None:
    config = read_operator({"cancel": "ops/cancel", "goals": GOALS})
    assert config.topics == {OperatorCommand.CANCEL: "ops/cancel"}
    assert config.goals[GoalState.RUNNING].positions == {"Robot": 0, "Goal": 1, "Priority": 2}
    with pytest.raises(ConfigError, match="unknown key 'cancle'; did you mean 'cancel'"):
        read_operator({"cancle": "ops/cancel"})
    with pytest.raises(ConfigError, match="no wildcards"):
        read_operator({"hold": "ops/#"})
    with pytest.raises(ConfigError, match="names no Goal variable"):
        read_operator({"goals": {"running": "task(R, G, P)"}})
    with pytest.raises(ConfigError, match="unknown goal state 'runing'"):
        read_operator({"goals": {"runing": "task(Robot, Goal, Priority)"}})
    assert area_payload("a1", "47.0, 15.4", "80", "2") == {
        "goal": "a1", "center": [47.0, 15.4], "radius": 80.0, "priority": 2}
    for args, problem in ((("A1", "1,2", "1", "1"), "lowercase identifier"),
                          (("a1", "1,2", "-3", "1"), "more than 0 m"),
                          (("a1", "91,2", "1", "1"), "not a position"),
                          (("a1", "1,2", "1", "high"), "whole number")):
        with pytest.raises(PayloadError, match=problem):
            area_payload(*args)


def test_mrss_check_names_a_bad_operator_table_at_its_line(tmp_path: Path) -> None:
    project = tmp_path / "tuimission"
    shutil.copytree(HERE / "tuimission", project)
    (project / "agent.asl").write_text((Path(__file__).parents[2] / "projects" / "wildfire"
                                        / "agent.asl").read_text())
    toml = project / "project.toml"
    text = toml.read_text().replace("../../../projects/wildfire/agent.asl", "agent.asl")
    toml.write_text(text.replace('failed = "failed_goal(Goal)"', 'failed = "faild_goal(Goal)"'))
    report = check_project(load_file(toml))
    found = [f for f in report.warnings if "faild_goal" in f.message]
    assert found and found[0].line == text.splitlines().index('failed = "failed_goal(Goal)"') + 1
    toml.write_text(text.replace('hold = "ops/hold"', 'halt = "ops/hold"'))
    errors = check_project(load_file(toml)).errors
    assert any("unknown key 'halt'" in f.message for f in errors), errors


def test_goals_follow_the_agents_beliefs_and_end_as_cancelled_failed_or_done() -> None:
    model = GoalsModel(read_operator({"goals": GOALS}).goals)
    assert model.apply_beliefs(["task(uav1,a1,2)[source(self)]", "queued(uav1,a2,1,cover)",
                                "robot(uav1)"], when=10.0)
    rows = {v.goal: (v.state, v.robot, v.priority) for v in model.newest_first()}
    assert rows == {"a1": (GoalState.RUNNING, "uav1", 2), "a2": (GoalState.QUEUED, "uav1", 1)}
    assert model.current_goal("uav1") is not None and model.current_goal("uav1").goal == "a1"
    assert not model.apply_beliefs(["task(uav1,a1,2)", "queued(uav1,a2,1,cover)"], when=11.0)
    model.cancelled_here.add("a1")
    model.apply_beliefs(["task(uav1,a2,1)", "queued(uav1,a3,1,cover)"], when=12.0)
    model.apply_beliefs(["failed_goal(a3)"], when=13.0)
    states = {v.goal: v.state for v in model.newest_first()}
    assert states == {"a1": GoalState.CANCELLED, "a2": GoalState.DONE, "a3": GoalState.FAILED}


def test_goal_commands_are_refused_with_the_reason(endpoints: BusEndpoints) -> None:
    """Read-only, undeclared, or no broker: nothing is sent, the status line says why."""
    async def body() -> None:
        channel = MissionChannel(read_operator({"hold": "ops/hold"}), lambda: None)
        for kw, expected in (({"readonly": True, "mission": channel}, "read-only"),
                             ({}, "the project declares no hold command"),
                             ({"mission": channel}, "no MQTT broker known")):
            app = MrssApp(endpoints, project="demo", mind_every=0, tree_every=0,
                          world_every=0, **kw)  # type: ignore[arg-type]
            async with app.run_test(size=(120, 35)) as pilot:
                bar = app.query_one(OperatorBar)
                await pilot.press("H")
                if isinstance(app.screen, ConfirmScreen):
                    await pilot.press("y")
                await until(pilot, lambda b=bar, e=expected: e in b.status_text,  # type: ignore[misc]
                            message=expected)
                assert bar.status_error
    run(body())


def test_declared_done_and_cancelled_patterns_say_how_a_goal_ended() -> None:
    """The agent says it: nothing is inferred from the actions or the operator's keys."""
    goals = dict(GOALS, done="done_goal(Goal)", cancelled="cancelled_goal(Goal)")
    model = GoalsModel(read_operator({"goals": goals}).goals)
    model.apply_beliefs(["task(uav1,a1,2)", "queued(uav1,a2,1,cover)"], when=1.0)
    model.cancelled_here.add("a2")  # the operator pressed cancel; the agent finished it
    model.apply_beliefs(["done_goal(a1)", "done_goal(a2)", "cancelled_goal(a3)"], when=2.0)
    states = {v.goal: v.state for v in model.newest_first()}
    assert states == {"a1": GoalState.DONE, "a2": GoalState.DONE, "a3": GoalState.CANCELLED}
    # ended while watched (a3 was first seen over: no news, e.g. a dashboard attaching)
    assert [(v.goal, v.state) for v in model.take_ended()] == [
        ("a1", GoalState.DONE), ("a2", GoalState.DONE)]
    assert model.take_ended() == []
    # sent again: open again, whatever ending is still believed
    model.apply_beliefs(["done_goal(a1)", "task(uav1,a1,3)"], when=3.0)
    assert model.goals["a1"].state is GoalState.RUNNING and model.goals["a1"].priority == 3
