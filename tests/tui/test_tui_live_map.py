"""Against a live tuimap (bus, embedded world model, a robot driving east): the map shows
the world model's seeded objects and the robot moving; a hotspot added to the world
model appears on the map and, through its rule's `hotspot_detected` percept, as an
alert that `A` acknowledges."""

from __future__ import annotations

import shutil
import tempfile
from collections.abc import Iterator
from pathlib import Path

import pytest

from mrss.bus import BusEndpoints, Publisher
from mrss.messages import DataRequest
from mrss.tui.app import MrssApp
from mrss.tui.models.alerts import AlertKind
from mrss.tui.widgets.alerts_strip import AlertsStrip
from mrss.tui.widgets.map_panel import MapPanel
from mrss.world.topics import WM_REQUEST_TOPIC
from tests.tui.conftest import HERE, supervise
from tests.tui.tui_helpers import run, until


@pytest.fixture()
def tuimap() -> Iterator[Path]:
    """tests/tui/tuimap running; its run dir."""
    run_dir = Path(tempfile.mkdtemp(prefix="mrss-tuimap-"))
    try:
        yield from supervise("tuimap", HERE, run_dir)
    finally:
        shutil.rmtree(run_dir, ignore_errors=True)


@pytest.mark.slow
def test_the_live_map_shows_the_world_model_and_a_moving_robot_and_a_hotspot_alert(
        tuimap: Path) -> None:
    endpoints = BusEndpoints.ipc(tuimap)

    async def body() -> None:
        app = MrssApp(endpoints, project="tuimap", mind_every=0, tree_every=0,
                      world_every=0.5)
        async with app.run_test(size=(180, 50)) as pilot:
            panel = app.query_one(MapPanel)
            await until(pilot, lambda: {"area1", "base1", "w1"} <= set(app.map_model.objects),
                        timeout=30, message="the seeded objects on the map")
            await until(pilot, lambda: panel.marker_cell("ugv1"), timeout=15,
                        message="ugv1 on the map")
            first = app.map_model.robots["ugv1"].lon
            await until(pilot, lambda: app.map_model.robots["ugv1"].lon != first,
                        message="ugv1 moved")
            assert app.map_model.robots["ugv1"].heading == 90.0
            await until(pilot, lambda: "ugv1" in app.map_model.plans, timeout=15,
                        message="ugv1's plan on the map")
            assert len(app.map_model.plans["ugv1"].waypoints) == 4
            assert len(app.map_model.robots["ugv1"].track) >= 2
            # an operator adds a hotspot far from water: on the map, and an alert
            with Publisher(endpoints, src="operator") as pub:
                assert pub.wait_connected(10)
                pub.publish(DataRequest(request_id="op-1", function="wm.upsert", args=[
                    {"id": "h9", "kind": "hotspot",
                     "position": {"lat": 47.0665, "lon": 15.4435}}]), topic=WM_REQUEST_TOPIC)
                pub.flush()
            await until(pilot, lambda: "h9" in app.map_model.objects, timeout=15,
                        message="the new hotspot on the map")
            strip = app.query_one(AlertsStrip)
            await until(pilot, lambda: any(a.kind == AlertKind.HOTSPOT and "h9" in a.subject
                                           for a in app.alerts.unacked()),
                        timeout=15, message="the hotspot alert")
            assert "hotspot: hotspot_detected(h9" in strip.plain
            await pilot.press("A")
            assert app.alerts.unacked() == []
    run(body())
