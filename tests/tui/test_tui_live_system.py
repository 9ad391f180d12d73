"""The dashboard against a live `mrss supervise busdemo`: tree over the bus, faults that bite."""

from __future__ import annotations

from pathlib import Path

import pytest
from textual.widgets import Input, Sparkline

from mrss.bus import BusEndpoints, Publisher
from mrss.config.loader import load_project
from mrss.messages import Command, Percept
from mrss.tui.app import MrssApp
from mrss.tui.details import ComponentDetail, RobotDetail
from mrss.tui.discovery import find_endpoints
from mrss.tui.widgets.actions_table import ActionsTable
from mrss.tui.widgets.log_pane import LogPane
from mrss.tui.widgets.mind_inspector import MindInspector
from mrss.tui.widgets.robots_table import RobotsTable
from mrss.tui.widgets.supervision_table import SupervisionTable
from tests.tui.tui_helpers import confirmed, has_row, row_text, run, until

COMPONENTS = ("bus", "rcl", "reasoner", "telemetry")


def test_dashboard_shows_the_live_tree_and_its_fault_keys_kill_hang_crash_a_component(
        busdemo: Path) -> None:
    endpoints, name = find_endpoints("busdemo", run_dir=busdemo)
    assert name == "busdemo"

    spec = load_project("busdemo").supervisor.spec

    async def body() -> None:
        app = MrssApp(endpoints, project=name, mind_every=0, tree_every=0.3,
                      restart_budget=(spec.intensity, spec.period))
        async with app.run_test(size=(180, 50)) as pilot:
            table = app.query_one(SupervisionTable)
            row = "busdemo/announcer"

            def announcer(inc: int) -> list[str] | None:
                if not has_row(table, row):
                    return None
                cells = row_text(table, row)
                return cells if cells[1] == "running" and cells[5] == str(inc) else None

            await until(pilot, lambda: announcer(1), timeout=30, message="announcer running")
            assert table.shown_keys() == ["busdemo", "busdemo/bus", row]
            table.focus()
            await pilot.press("down", "down")
            assert table.selected_key == row
            await pilot.press("k", "k")
            cells = await until(pilot, lambda: announcer(2), timeout=30,
                                message="announcer killed and restarted")
            assert cells[2] == "1" and "SIGKILL" in cells[7]  # restarts, last reason
            log = app.query_one(LogPane)
            await until(pilot, lambda: any("fault kill injected into announcer" in line
                                           for line in log.lines_text()), message="fault logged")
            # Enter: the component's detail, with its budget, process and log
            await pilot.press("enter")
            detail = await until(pilot, lambda: isinstance(app.screen, ComponentDetail)
                                 and app.screen, message="the component's detail")
            pid = row_text(table, row)[4]
            budget = f"restart budget  1 of {spec.intensity} in {spec.period:g} s\n"
            text = await until(pilot, lambda: "CPU measuring" not in detail.body_text
                               and budget in detail.body_text and detail.body_text,
                               message="CPU measured, the supervisor's budget count shown")
            assert f"pid             {pid}" in text
            assert "CPU " in text and " MiB" in text and "SIGKILL" in text
            assert "fault kill injected into announcer" in text.split("last log lines")[1]
            await pilot.press("escape")
            await pilot.press("h", "h")
            cells = await until(pilot, lambda: announcer(3), timeout=30,
                                message="hung announcer found and restarted")
            assert cells[2] == "2" and "hung" in cells[7]
            await pilot.press("x", "x")
            cells = await until(pilot, lambda: announcer(4), timeout=30,
                                message="crashed announcer restarted")
            assert cells[2] == "3" and "InjectedFault" in cells[7]
            # a bad fault request from elsewhere on the bus is refused, and said so
            with Publisher(endpoints, src="operator2") as other:
                assert other.wait_connected(10)
                other.publish(Command(command="fault", target="announcer",
                                      args={"fault": "explode"}))
                other.publish(Command(command="fault", target="nobody",
                                      args={"fault": "kill"}))
                other.publish(Command(command="stop", target="wildfire"))  # another system
            await until(pilot, lambda: sum("refused" in line for line in log.lines_text()) == 3,
                        message="three refusals logged")
            refusals = [line for line in log.lines_text() if "refused" in line]
            assert "unknown fault 'explode'" in refusals[0]
            assert "has no child 'nobody'" in refusals[1]
            assert "stop of 'wildfire' from operator2 refused: this is 'busdemo'" in refusals[2]
            assert announcer(4) is not None
    run(body())


@pytest.mark.slow
def test_operator_drives_a_live_reasoner_and_rcl_from_the_dashboard(tuidemo: Path) -> None:
    """Percept typed -> the agent acts -> the action shows up; teleop suspends and resumes
    it, the cancel key cancels it, and the mind inspector follows along."""
    endpoints = BusEndpoints.ipc(tuidemo)

    async def body() -> None:
        app = MrssApp(endpoints, project="tuidemo", mind_every=0.3, tree_every=0.5)
        async with app.run_test(size=(180, 50)) as pilot:
            sup = app.query_one(SupervisionTable)

            def picture() -> str:  # what the dashboard had, should this wait time out
                rows = {key: row_text(sup, key)[1] for key in sup.shown_keys()}
                return (f"rows {rows}; bus messages received {app.link.received}, proxy "
                        f"greetings {app.link.welcomes}")
            await until(pilot, lambda: [row_text(sup, f"tuidemo/{c}")[1] for c in COMPONENTS
                                        if has_row(sup, f"tuidemo/{c}")] == ["running"] * 4,
                        timeout=45, message="four components running", describe=picture)
            mind = app.query_one(MindInspector)
            await until(pilot, lambda: mind.snapshot is not None
                        and "robot(ugv1)[source(self)]" in mind.snapshot.beliefs,
                        timeout=10, message="the agent's beliefs")
            robots = app.query_one(RobotsTable)
            await until(pilot, lambda: has_row(robots, "ugv1")
                        and row_text(robots, "ugv1")[3].endswith("%"), message="telemetry")
            # Enter on a robot: every telemetry field and the sparklines, filling up
            robots.focus()
            await pilot.press("enter")
            detail = await until(pilot, lambda: isinstance(app.screen, RobotDetail)
                                 and app.screen, message="the robot's detail")
            for field in ("position.lat", "battery.remaining", "tank.level", "tank.capacity"):
                assert field in detail.body_text, detail.body_text
            view = app.robots.robots["ugv1"]
            await until(pilot, lambda: len(view.series.get("battery", ())) >= 3,
                        message="battery samples")
            spark = detail.query_one("#spark-battery", Sparkline)
            await until(pilot, lambda: len(spark.data or []) >= 3, message="battery sparkline")
            assert set(view.series) == {"battery", "tank"}  # the demo sends no altitude
            assert spark.display and not detail.query_one("#spark-altitude", Sparkline).display
            await pilot.press("escape")
            await pilot.press("p")
            app.query_one("#percept", Input).value = "fire(area1)"
            await pilot.press("enter")
            actions = app.query_one(ActionsTable)

            def action_state() -> str:
                keys = actions.shown_keys()
                if not keys:
                    return ""
                row = row_text(actions, keys[0])
                assert row[1:4] == ["patrol", "ugv1", "area1"]
                return f"{row[4]}: {row[5]}"

            await until(pilot, lambda: action_state() == "running: ", timeout=10,
                        message="the agent's patrol running")
            assert mind.snapshot is not None
            await until(pilot, lambda: mind.snapshot is not None and
                        "fire(area1)[source(percept)]" in mind.snapshot.beliefs
                        and len(mind.snapshot.intentions) == 1, message="intention in mind")
            robots.focus()
            await confirmed(pilot, "t")  # ugv1 (the first row) to teleop: its action suspended
            await until(pilot, lambda: action_state() == "suspended: robot in teleop",
                        message="suspended by teleop")
            await until(pilot, lambda: row_text(robots, "ugv1")[6] == "on", message="teleop on")
            await confirmed(pilot, "t")
            await until(pilot, lambda: action_state().startswith("running"),
                        message="resumed after teleop")
            actions.focus()
            await confirmed(pilot, "c")
            await until(pilot, lambda: action_state().startswith("cancelled"),
                        message="cancelled from the dashboard")
            await until(pilot, lambda: mind.snapshot is not None
                        and not mind.snapshot.intentions, message="intention gone from mind")
            # the mind's history: the percept's arrival is a diff; freeze, step, live
            history = mind.history
            assert {e.incarnation for e in history.entries} == {1}
            assert any("fire(area1)[source(percept)]" in history.diff(e)[0]
                       for e in history.entries)
            mind.focus()
            await pilot.press("f")
            frozen = mind.shown
            assert frozen is not None and "frozen" in str(mind.border_subtitle)
            app.link.publish(Percept(literal="fire(area3)"))
            await until(pilot, lambda: "fire(area3)[source(percept)]" in
                        history.entries[-1].snapshot.beliefs, message="a newer snapshot kept")
            assert mind.shown is frozen and mind.snapshot is frozen.snapshot
            await pilot.press("left_square_bracket")
            assert mind.shown is not None and mind.shown.serial < frozen.serial
            assert "history" in str(mind.border_subtitle)
            await pilot.press("end")
            assert mind.snapshot is not None
            assert "fire(area3)[source(percept)]" in mind.snapshot.beliefs
            assert str(mind.border_subtitle).startswith("live")
    run(body())
