"""The dashboard against a live fleet (`mrss supervise tuifleet`: the RCL with three
ground robots, the agent addressing each fire to a role): who holds a task and why it
won, from the bids the allocator published; decommission and recommission from the
robots table, the task handed on, the hand-over in the log and the alerts; a task
waiting, and for what."""

from __future__ import annotations

from pathlib import Path
from typing import Any

import pytest
from textual.widgets import Input

from mrss.bus import BusEndpoints
from mrss.config.operator_commands import FieldType
from mrss.incident.entries import IncidentKind
from mrss.testing import wait_until
from mrss.tui import stand_down
from mrss.tui.app import MrssApp
from mrss.tui.command_form import CommandForm
from mrss.tui.confirm import ConfirmScreen
from mrss.tui.details import ActionDetail
from mrss.tui.models.alerts import AlertKind
from mrss.tui.widgets.actions_table import ActionsTable
from mrss.tui.widgets.log_pane import LogPane
from mrss.tui.widgets.mind_inspector import MindInspector
from mrss.tui.widgets.robots_table import RobotsTable
from tests.incident.test_incident_live import rows
from tests.tui.tui_helpers import confirmed, has_row, row_text, run, until


async def fire_once_ready(pilot: Any, app: MrssApp, literal: str) -> RobotsTable:
    """Once the three robots are available and the reasoner answers (so it hears the
    percept: one sent before its subscription would be lost, the percept line is not a
    reliable channel), `literal` on the percept line; the robots table."""
    robots = app.query_one(RobotsTable)
    await until(pilot, lambda: all(has_row(robots, r) and row_text(robots, r)[1] == "yes"
                                   for r in ("ugv1", "ugv2", "ugv3")),
                timeout=45, message="three robots available")
    await until(pilot, lambda: app.query_one(MindInspector).snapshot is not None,
                timeout=30, message="the agent's mind")
    await pilot.press("p")
    app.query_one("#percept", Input).value = literal
    await pilot.press("enter")
    return robots


@pytest.mark.slow
def test_operator_sees_why_a_robot_won_and_decommissions_it_to_hand_its_task_on(
        tuifleet: Path) -> None:
    endpoints = BusEndpoints.ipc(tuifleet)

    async def body() -> None:
        app = MrssApp(endpoints, project="tuifleet", mind_every=0.5, tree_every=0.5)
        async with app.run_test(size=(200, 50)) as pilot:
            robots = await fire_once_ready(pilot, app, "fire(f1, 48.0, 16.0)")
            actions = app.query_one(ActionsTable)

            def task_row(goal: str) -> list[str]:
                for key in actions.shown_keys():
                    row = row_text(actions, key)
                    if row[3] == goal:
                        return row
                return []

            # ugv1 stands on the fire: it wins; the runners-up say how they compared
            row = await until(pilot, lambda: (r := task_row("f1")) and r[2] == "ugv1"
                              and r[4] == "running" and r, timeout=30,
                              message="the fire's task running on ugv1")
            reason = row[5]
            assert reason.startswith("ugv1: finish in 0 s, 90 % battery after; "), reason
            assert "ugv2: finish in " in reason and "ugv3: finish in " in reason
            uuid = next(k for k in actions.shown_keys() if row_text(actions, k)[3] == "f1")
            # Enter: the allocation in full (its role, holder, every bid)
            actions.focus()
            actions.move_cursor(row=actions.shown_keys().index(uuid))
            await pilot.press("enter")
            detail = await until(pilot, lambda: isinstance(app.screen, ActionDetail)
                                 and app.screen, message="the action's detail")
            text = detail.body_text
            assert "role       any(ugv) near 48.0000, 16.0000" in text, text
            assert "ranked by  quickest_finish" in text and "bids (3, best first)" in text
            await pilot.press("escape")

            # d on ugv1: asked first (naming the task it hands on); n leaves it in service
            robots.focus()
            robots.move_cursor(row=robots.shown_keys().index("ugv1"))
            await pilot.press("d")
            question = await until(pilot, lambda: isinstance(app.screen, ConfirmScreen)
                                   and app.screen, message="the decommission question")
            assert question.question == "Decommission ugv1: take it out of service?"
            assert any(d.startswith("tasks handed to other robots (addressed to a role): "
                                    f"patrol f1 ({uuid[:8]})") for d in question.details)
            await pilot.press("n")
            assert row_text(robots, "ugv1")[1] == "yes"
            await confirmed(pilot, "d")
            await until(pilot, lambda: row_text(robots, "ugv1")[1] == "decommissioned",
                        timeout=20, message="ugv1 decommissioned")
            row = await until(pilot, lambda: (r := task_row("f1")) and r[2] == "ugv2"
                              and r[4] == "running" and r, timeout=30,
                              message="the task handed to ugv2")
            assert row[5].startswith("reassigned from ugv1: ugv2: finish in "), row[5]
            assert "ugv1 unavailable: decommissioned by the operator" in row[5]
            alert = app.alerts.alerts.get((AlertKind.REASSIGNED.value,
                                           f"patrol f1 ({uuid[:8]})"))
            assert alert is not None and alert.text.startswith("from ugv1 to ugv2")
            log = app.query_one(LogPane)
            await until(pilot, lambda: any("task reassigned: patrol f1" in line
                                           and "from ugv1 to ugv2" in line
                                           for line in log.lines_text()),
                        message="the hand-over in the log")

            # a second fire while ugv3 is the only robot left, then ugv3 out too:
            # it waits, and says for what
            await pilot.press("p")
            app.query_one("#percept", Input).value = "fire(f2, 48.01, 16.0)"
            await pilot.press("enter")
            await until(pilot, lambda: (r := task_row("f2")) and r[2] == "ugv3"
                        and r[4] == "running", timeout=30, message="f2 on ugv3")
            robots.focus()
            robots.move_cursor(row=robots.shown_keys().index("ugv3"))
            await confirmed(pilot, "d")
            row = await until(pilot, lambda: (r := task_row("f2")) and r[4] == "waiting"
                              and r, timeout=30, message="f2 waiting")
            assert row[2] == "any(ugv) near 48.0100, 16.0000"
            assert row[5].startswith("every capable robot is busy: ugv2 busy with "
                                     "priority 0"), row[5]
            assert "ugv1 unavailable: decommissioned by the operator" in row[5]
            # recommissioned, ugv1 takes the waiting task
            robots.move_cursor(row=robots.shown_keys().index("ugv1"))
            await pilot.press("d")
            question = await until(pilot, lambda: isinstance(app.screen, ConfirmScreen)
                                   and app.screen, message="the recommission question")
            assert question.question == "Recommission ugv1: back in service?"
            await pilot.press("y")
            await until(pilot, lambda: row_text(robots, "ugv1")[1] == "yes", timeout=20,
                        message="ugv1 back in service")
            row = await until(pilot, lambda: (r := task_row("f2")) and r[2] == "ugv1"
                              and r[4] == "running" and r, timeout=30,
                              message="f2 awarded to ugv1")
            assert row[5].startswith("reassigned from ugv3: ugv1: finish in "), row[5]
    run(body())


@pytest.mark.slow
def test_operator_stands_down_the_robots_in_an_area_and_lifts_it_with_one_key(
        tuifleet: Path) -> None:
    endpoints = BusEndpoints.ipc(tuifleet)
    # around ugv1 (48.0, 16.0) only: ugv2 is 550 m north
    square = "47.999,15.999; 47.999,16.001; 48.001,16.001; 48.001,15.999"

    async def body() -> None:
        app = MrssApp(endpoints, project="tuifleet", mind_every=0.5, tree_every=0.5)
        async with app.run_test(size=(200, 50)) as pilot:
            await fire_once_ready(pilot, app, "fire(f1, 48.0, 16.0)")
            actions = app.query_one(ActionsTable)

            def f1() -> list[str]:
                rows = [row_text(actions, k) for k in actions.shown_keys()]
                return next((r for r in rows if r[3] == "f1"), [])

            await until(pilot, lambda: (r := f1()) and r[2] == "ugv1" and r[4] == "running",
                        timeout=30, message="f1 running on ugv1",
                        describe=lambda: str([row_text(actions, k)
                                              for k in actions.shown_keys()]))
            # the area as drawn (R or Z on the map offers the same form)
            app.steering.open_stand_down(stand_down.spec(FieldType.POLYGON),
                                         FieldType.POLYGON, square)
            form = await until(pilot, lambda: isinstance(app.screen, CommandForm)
                               and app.screen.query("#cmd-area") and app.screen,
                               message="the stand-down form")
            assert form.query_one("#cmd-area", Input).value == square
            assert form.query_one("#cmd-mode", Input).value == "hold"
            form.query_one("#cmd-robots", Input).value = "ugv"
            await pilot.press("ctrl+s")
            question = await until(pilot, lambda: isinstance(app.screen, ConfirmScreen)
                                   and app.screen, message="the stand-down question")
            assert question.question == "Stand down robots with ugv in this area (hold)?"
            await pilot.press("y")
            log = app.query_one(LogPane)
            line = await until(pilot, lambda: next(  # the dashboard's line of the answer
                (x for x in log.lines_text() if "(hold): ugv1 held" in x), ""),
                timeout=20, message="the RCL's answer in the log")
            assert list(app.map_model.stand_downs) == [line.split("stand-down ")[1].split()[0]]
            row = await until(pilot, lambda: (r := f1()) and r[4] == "suspended" and r,
                              timeout=20, message="f1 suspended on ugv1")
            assert row[2] == "ugv1" and "stand-down sd-" in row[5], row

            await pilot.press("escape", "U")  # out of the percept line; U lifts, asked
            question = await until(pilot, lambda: isinstance(app.screen, ConfirmScreen)
                                   and app.screen, message="the lift question")
            assert question.question == "Lift every stand-down: the robots go on?"
            await pilot.press("y")
            await until(pilot, lambda: any("lifted: ugv1 go on" in x for x in log.lines_text()),
                        timeout=20, message="the lift in the log")
            await until(pilot, lambda: (r := f1()) and r[4] == "running", timeout=20,
                        message="f1 running again")
            assert app.map_model.stand_downs == {}
    run(body())
    # the system's incident record has the command (with its author) and the RCL's word

    def recorded(kind: IncidentKind, text: str) -> bool:
        return any(e.kind is kind and text in e.text for e in rows(tuifleet))

    wait_until(lambda: recorded(IncidentKind.ROBOT, "lifted: ugv1 go on"), timeout=20,
               message="the lift in the incident record")
    assert recorded(IncidentKind.ROBOT, "(hold): ugv1 held")
    assert recorded(IncidentKind.OPERATOR, "ctl.stand_down sd-")
    assert recorded(IncidentKind.OPERATOR, "ctl.stand_down_lift")
