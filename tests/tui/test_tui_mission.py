"""The mission panel against a live system running the wildfire agent: the operator's
goal commands go to the agent as the project's events (MQTT, the events manager,
percepts), never around it."""

from __future__ import annotations

from pathlib import Path

from textual.widgets import Input

from mrss.bus import BusEndpoints
from mrss.config.loader import load_project
from mrss.tui.app import MrssApp
from mrss.tui.area_form import AreaForm
from mrss.tui.command_form import CommandMenu
from mrss.tui.confirm import ConfirmScreen
from mrss.tui.details import ActionDetail
from mrss.tui.mission import project_mission
from mrss.tui.widgets.actions_table import ActionsTable
from mrss.tui.widgets.log_pane import LogPane
from mrss.tui.widgets.mission_panel import MissionPanel
from mrss.tui.widgets.robots_table import RobotsTable
from tests.tui.conftest import HERE
from tests.tui.tui_helpers import confirmed, has_row, row_text, run, until


def test_operator_goal_commands_reach_the_agent_and_a_cancel_is_a_cancel(
        tuimission: Path) -> None:
    config = load_project("tuimission", HERE)
    mission = project_mission(config.directory, config.file, config.sections, tuimission)
    assert mission is not None

    async def body() -> None:
        app = MrssApp(BusEndpoints.ipc(tuimission), project="tuimission", mind_every=0.3,
                      tree_every=0.5, mission=mission)
        async with app.run_test(size=(200, 50)) as pilot:
            panel = app.query_one(MissionPanel)
            mind = app.query_one("#mind")
            await until(pilot, lambda: getattr(mind, "snapshot", None) is not None,
                        timeout=30, message="the agent answers")

            def goal(name: str) -> list[str]:
                return row_text(panel, name) if has_row(panel, name) else []

            async def open_area() -> AreaForm:
                # the project declares its own commands too: n opens their menu
                panel.focus()
                await pilot.press("n")
                await until(pilot, lambda: isinstance(app.screen, CommandMenu),
                            message="the command menu")
                await pilot.press("end", "enter")  # area: last on the menu
                return await until(pilot, lambda: isinstance(app.screen, AreaForm)
                                   and app.screen, message="the area form")

            async def add_area(name: str, priority: str) -> None:
                form = await open_area()
                for key, value in (("name", name), ("center", "47.07,15.43"),
                                   ("radius", "80"), ("priority", priority)):
                    form.query_one(f"#area-{key}", Input).value = value
                await pilot.press("ctrl+s")

            # a mistake stays in the form, nothing is sent
            form = await open_area()
            form.query_one("#area-name", Input).value = "a1"
            form.query_one("#area-center", Input).value = "north"
            await pilot.press("ctrl+s")
            assert isinstance(app.screen, AreaForm) and "centre must be LAT,LON" in form.error
            await pilot.press("escape")
            await add_area("a1", "2")
            await until(pilot, lambda: goal("a1")[1:4] == ["running", "uav1", "2"],
                        timeout=20, message="a1 running on uav1")
            robots = app.query_one(RobotsTable)
            await until(pilot, lambda: has_row(robots, "uav1")
                        and row_text(robots, "uav1")[5] == "a1", message="uav1's goal a1")
            # Enter on the running action: its detail, progress moving while it is open
            actions = app.query_one(ActionsTable)
            actions.focus()
            actions.move_cursor(row=0)
            await pilot.press("enter")
            detail = await until(pilot, lambda: isinstance(app.screen, ActionDetail)
                                 and app.screen, message="the action's detail")
            uuid = actions.selected_key or ""
            assert len(uuid) == 32 and f"uuid       {uuid}" in detail.body_text
            assert "requester  reasoner" in detail.body_text
            assert "args       ['any([uav,camera])', 'a1']" in detail.body_text  # asked of a role
            first = detail.body_text.split("leg=")[0]
            await until(pilot, lambda: detail.body_text.split("leg=")[0] != first,
                        message="progress moving on the open detail")
            await pilot.press("escape")
            await add_area("a2", "1")
            # addressed to any UAV with a camera: uav1 is busy, the RCL gives it to uav2
            await until(pilot, lambda: goal("a2")[1:4] == ["running", "uav2", "1"],
                        message="a2 running on uav2")
            # + raises a2's priority, through the agent's prioritychange (asked again)
            panel.move_cursor(row=panel.shown_keys().index("a2"))
            await pilot.press("plus")
            await until(pilot, lambda: goal("a2")[3] == "2", message="a2 priority 2")
            # cancel a1: the agent's own plan cancels it (not a failure); a2 goes on
            panel.move_cursor(row=panel.shown_keys().index("a1"))
            await pilot.press("c")
            screen = await until(pilot, lambda: isinstance(app.screen, ConfirmScreen)
                                 and app.screen, message="cancel question")
            assert screen.question == "Cancel goal a1 (running on uav1)?"
            await pilot.press("y")
            await until(pilot, lambda: goal("a1")[1] == "cancelled", message="a1 cancelled")
            await until(pilot, lambda: goal("a2")[1] == "running", message="a2 goes on")
            snap = getattr(mind, "snapshot", None)
            assert snap is not None and "failed_goal(a1)" not in " ".join(snap.beliefs)
            log = app.query_one(LogPane)
            await until(pilot, lambda: any("cancelling goal a1" in line
                                           for line in log.lines_text()),
                        message="the agent's cancel plan ran")
            # the agent said how a1 ended (cancelled_goal), and the log has the line
            assert any("goal a1 cancelled (uav1)" in line for line in log.lines_text())
            covers = [row_text(actions, k) for k in actions.shown_keys()]
            a1 = [r for r in covers if r[1:4] == ["cover", "uav1", "a1"]]
            assert a1 and a1[0][4] == "cancelled", covers
            timeline = ActionDetail(app.actions, uuid).body_text.split("timeline")[1]
            assert [line.split()[1] for line in timeline.splitlines()[1:]] == [
                "requested", "pending", "running", "cancelled"], repr(timeline)
            assert "cancelled by the agent" in timeline  # the agent's plan, not the RCL alone
            # all robots hold: the agent suspends every robot's actions, a2's among them;
            # lifting the hold resumes it
            await confirmed(pilot, "H")
            await until(pilot, lambda: goal("a2")[1] == "suspended", message="held")
            await confirmed(pilot, "H")
            await until(pilot, lambda: goal("a2")[1] == "running", message="going on")
            assert not any("not done" in line for line in log.lines_text())
    run(body())
