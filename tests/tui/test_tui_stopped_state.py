"""After a real `mrss supervise` ends, the dashboard shows every robot as unknown and
every component as stopped, not the state it last heard."""

from __future__ import annotations

from pathlib import Path

from mrss.bus import BusEndpoints
from mrss.tui.app import MrssApp
from mrss.tui.confirm import ConfirmScreen
from mrss.tui.widgets.robots_table import RobotsTable
from mrss.tui.widgets.supervision_table import SupervisionTable
from tests.tui.tui_helpers import has_row, row_text, run, until


def test_robots_and_components_show_stopped_once_the_system_stopped(tuimission: Path) -> None:
    async def body() -> None:
        app = MrssApp(BusEndpoints.ipc(tuimission), project="tuimission", mind_every=0,
                      tree_every=0.5, stale_after=2.0)
        async with app.run_test(size=(200, 50)) as pilot:
            robots = app.query_one(RobotsTable)
            tree = app.query_one(SupervisionTable)
            await until(pilot, lambda: has_row(robots, "uav1")
                        and row_text(robots, "uav1")[1:3] == ["yes", "up"], timeout=30,
                        message="uav1 up")
            await until(pilot, lambda: "running" in app.supervision.nodes.get(
                "tuimission/rcl", type("n", (), {"state": ""})).state, timeout=30,
                message="the rcl running")
            await pilot.press("X")
            await until(pilot, lambda: isinstance(app.screen, ConfirmScreen), message="ask")
            await pilot.press("y")
            await until(pilot, lambda: app.banner_text().startswith("system stopped"),
                        timeout=60, message="the end seen")
            await until(pilot, lambda: row_text(robots, "uav1")[1:3] == ["?", "unknown"],
                        message="uav1 unknown")
            for robot in ("uav1", "ugv1"):
                assert row_text(robots, robot)[1:3] == ["?", "unknown"]
            states = {n.path: n.state for n in app.supervision.nodes.values()}
            assert states and all(s in ("stopped", "exited", "gave up")
                                  for s in states.values()), states
            await until(pilot, lambda: all("running" not in " ".join(row_text(tree, k))
                                           for k in tree.shown_keys()),
                        message="no component shown running")
    run(body())
