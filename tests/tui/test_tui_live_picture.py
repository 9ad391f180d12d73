"""Against a live tuidemo: a dashboard that attaches late sees the whole picture at once
(robot states, the running action by name) and its progress moving; q detaches without
touching the system; X stops the system through the root supervisor."""

from __future__ import annotations

from pathlib import Path

import pytest
from textual.widgets import Input

from mrss.bus import BusEndpoints
from mrss.testing import WaitTimeout, wait_until
from mrss.tui.app import MrssApp
from mrss.tui.widgets.actions_table import ActionsTable
from mrss.tui.widgets.mind_inspector import MindInspector
from mrss.tui.widgets.robots_table import RobotsTable
from mrss.tui.widgets.supervision_table import SupervisionTable
from tests.tui.tui_helpers import has_row, row_text, run, until

COMPONENTS = ("bus", "rcl", "reasoner", "telemetry")


@pytest.mark.slow
def test_a_late_dashboard_gets_the_whole_picture_then_progress_and_x_stops_the_system(
        tuidemo: Path) -> None:
    endpoints = BusEndpoints.ipc(tuidemo)

    async def start_patrol() -> None:
        app = MrssApp(endpoints, project="tuidemo", mind_every=0.3, tree_every=0.5)
        async with app.run_test(size=(180, 50)) as pilot:
            sup = app.query_one(SupervisionTable)
            await until(pilot, lambda: [row_text(sup, f"tuidemo/{c}")[1] for c in COMPONENTS
                                        if has_row(sup, f"tuidemo/{c}")] == ["running"] * 4,
                        timeout=30, message="four components running")
            mind = app.query_one(MindInspector)  # the reasoner answers: it hears percepts
            await until(pilot, lambda: mind.snapshot is not None, timeout=15,
                        message="the agent's mind")
            actions = app.query_one(ActionsTable)
            await pilot.press("p")
            app.query_one("#percept", Input).value = "fire(area1)"
            await pilot.press("enter")
            await until(pilot, lambda: actions.row_count and row_text(
                actions, actions.selected_key or "")[4] == "running", message="running")
            await pilot.press("escape", "q")  # leave the percept line; q detaches
            await until(pilot, lambda: not app.is_running, message="detached")

    async def attach_late() -> None:
        app = MrssApp(endpoints, project="tuidemo", mind_every=0, tree_every=0,
                      stale_after=2.0)
        async with app.run_test(size=(180, 50)) as pilot:
            robots, actions = app.query_one(RobotsTable), app.query_one(ActionsTable)
            # from the snapshot: no robot state changed since we attached
            await until(pilot, lambda: all(has_row(robots, r) and
                                           row_text(robots, r)[1:3] == ["yes", "up"]
                                           for r in ("ugv1", "ugv2")),
                        timeout=15, message="both robots available, links up")
            await until(pilot, lambda: actions.row_count == 1, message="the running action")
            # the RCL's robot actors, from its snapshot's tree: not only from events seen
            await until(pilot, lambda: {"tuidemo/rcl/robots/ugv1", "tuidemo/rcl/robots/ugv2"}
                        <= set(app.supervision.nodes), message="the actor rows")
            uuid = actions.selected_key or ""
            row = row_text(actions, uuid)
            assert row[1:5] == ["patrol", "ugv1", "area1", "running"]  # named by the RCL
            seen: set[str] = set()

            def progress() -> bool:
                text = row_text(actions, uuid)[6]
                if text.endswith(("█", "░")) and "/1000 " in text:
                    seen.add(text.split(" ")[0])
                return len(seen) >= 2

            await until(pilot, progress, timeout=15, message="progress moving (n/1000)")
            # X: the root supervisor stops the whole system, in order
            await pilot.press("X")
            await until(pilot, lambda: "Stop the whole system tuidemo?" in
                        getattr(app.screen, "question", ""), message="the question")
            assert app.screen.details[0].startswith("components: bus, rcl")  # type: ignore[attr-defined]
            await pilot.press("y")
            try:
                await until(pilot, lambda: app.banner_text() ==
                            "system stopped: every component of tuidemo stopped",
                            timeout=30, message="the system stopped and went quiet")
            except WaitTimeout as exc:
                states = {p: n.state for p, n in app.supervision.nodes.items()}
                raise WaitTimeout(f"{exc}: banner {app.banner_text()!r}, tree {states}, "
                                  f"connected {app.link.connected}") from None
            assert app.is_running  # the last picture stays

    run(start_patrol())
    run(attach_late())
    log = tuidemo / "mrss.log"
    wait_until(lambda: "all components stopped" in log.read_text(), timeout=30,
               message="the root stopped every component")
    assert "stopping tuidemo: asked by tui" in log.read_text()
