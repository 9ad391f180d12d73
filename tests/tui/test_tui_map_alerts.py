"""The map, the alerts strip, help and the palette in the running app (Textual pilot, a
real proxy, a real world model answering `wm.list` over the bus)."""

from __future__ import annotations

from collections.abc import Iterator

import pytest
from textual.command import CommandList, CommandPalette

from mrss.actors.worldmodel.model import WorldModel
from mrss.actors.worldmodel.sqlite import SqliteWorldStore
from mrss.bus import BusEndpoints, Publisher, Subscriber
from mrss.messages import (
    DataReply,
    DataRequest,
    Envelope,
    Percept,
    RobotData,
    RobotState,
    SupEvent,
)
from mrss.tui.app import MrssApp
from mrss.tui.help import HelpScreen
from mrss.tui.widgets.alerts_strip import AlertsStrip
from mrss.tui.widgets.log_pane import LogPane
from mrss.tui.widgets.map_panel import MapPanel
from mrss.tui.widgets.robots_table import RobotsTable
from mrss.world.objects import WorldObject
from mrss.world.topics import WM_REPLY_TOPIC, WM_REQUEST_TOPIC, wm_reply_topic
from tests.tui.tui_helpers import Peer, connected, run, until

SIZE = (180, 50)


class WorldService:
    """The embedded world model's bus side: answers `dl.request.wm` from a real store."""

    def __init__(self, endpoints: BusEndpoints) -> None:
        self.world = WorldModel(SqliteWorldStore())
        self.pub = Publisher(endpoints, src="worldmodel")
        self.sub = Subscriber(endpoints, prefixes=[WM_REQUEST_TOPIC])
        self.sub.start(self._answer)
        assert self.sub.wait_connected(10) and self.pub.wait_connected(10)

    def _answer(self, env: Envelope) -> None:
        if isinstance(env.body, DataRequest):
            self.pub.publish(self.world.handle(env.body), topic=wm_reply_topic(env.src))

    def close(self) -> None:
        self.sub.close()
        self.pub.close()


@pytest.fixture()
def world(endpoints: BusEndpoints) -> Iterator[WorldService]:
    service = WorldService(endpoints)
    yield service
    service.close()


def make_app(endpoints: BusEndpoints, **kw: float | bool) -> MrssApp:
    opts: dict[str, float | bool] = {"mind_every": 0.0, "tree_every": 0.0, **kw}
    return MrssApp(endpoints, project="demo", **opts)  # type: ignore[arg-type]


def position(robot: str, lat: float, lon: float, heading: float) -> RobotData:
    return RobotData(robot=robot, data={"type": "position", "lat": lat, "lon": lon,
                                        "heading": heading})


def map_lines(panel: MapPanel) -> list[str]:
    width, height = panel.content_size.width, panel.content_size.height
    return panel.model.draw(panel.view, width, height).text()


def test_telemetry_moves_the_robot_marker_and_world_objects_show(
        endpoints: BusEndpoints, peer: Peer, world: WorldService) -> None:
    world.world.upsert(WorldObject.from_json(
        {"id": "h1", "kind": "hotspot", "position": {"lat": 43.6050, "lon": 1.4450}}))
    world.world.upsert(WorldObject.from_json(
        {"id": "base1", "kind": "base", "position": {"lat": 43.5950, "lon": 1.4350}}))

    async def body() -> None:
        app = make_app(endpoints, world_every=0.2)
        async with app.run_test(size=SIZE) as pilot:
            await connected(pilot, peer)
            panel = app.query_one(MapPanel)
            await until(pilot, lambda: set(app.map_model.objects) == {"h1", "base1"},
                        message="the world model's objects on the map")
            peer.publish(position("ugv1", 43.6000, 1.4400, 90.0), src="telemetry")
            await until(pilot, lambda: panel.marker_cell("ugv1"), message="ugv1 placed")
            first = panel.marker_cell("ugv1")
            assert first is not None
            await pilot.pause(0.05)
            screen = map_lines(panel)
            assert screen[first[1]][first[0]] == "→"  # heading 90: east
            assert "✹h1" in "\n".join(screen) and "⌂base1" in "\n".join(screen)
            # the robot drives north-east: its marker moves up and right, a track behind
            peer.publish(position("ugv1", 43.6040, 1.4440, 45.0), src="telemetry")
            await until(pilot, lambda: panel.marker_cell("ugv1") != first,
                        message="the marker moved")
            moved = panel.marker_cell("ugv1")
            assert moved is not None and moved[0] > first[0] and moved[1] < first[1]
            assert map_lines(panel)[moved[1]][moved[0]] == "↗"
            assert len(app.map_model.robots["ugv1"].track) == 2
            # zoom in (the view stops fitting), follow, fit again
            panel.focus()
            scale = panel.view.scale
            await pilot.press("plus")
            assert panel.view.scale < scale and not panel.auto_fit
            await pilot.press("f")
            assert panel.following == "ugv1"
            await pilot.pause(0.05)
            width, height = panel.content_size.width, panel.content_size.height
            assert panel.marker_cell("ugv1") == (width // 2, height // 2)
            await pilot.press("f")  # one robot: the next is "nobody"
            assert panel.following is None
            await pilot.press("0")
            assert panel.auto_fit
            assert "fit" in str(panel.border_title)
            # g on the robots table: the map follows the selected robot
            robots = app.query_one(RobotsTable)
            robots.focus()
            await until(pilot, lambda: robots.selected_key == "ugv1", message="ugv1 row")
            await pilot.press("g")
            assert panel.following == "ugv1"
    run(body())


def test_alerts_show_are_acknowledged_with_A_and_stay_in_the_log(
        endpoints: BusEndpoints, peer: Peer) -> None:
    async def body() -> None:
        app = make_app(endpoints, world_every=0.0)
        async with app.run_test(size=SIZE) as pilot:
            await connected(pilot, peer)
            strip = app.query_one(AlertsStrip)
            assert strip.plain.startswith("alerts: none new")
            peer.publish(RobotState(robot="ugv2", available=False, link="down",
                                    reason="no heartbeat"), src="rcl")
            peer.publish(RobotData(robot="ugv1", data={"type": "battery", "remaining": 9}),
                         src="telemetry")
            peer.publish(Percept(literal="hotspot_detected(h7,43.6,1.44)"), src="worldmodel")
            peer.publish(SupEvent(event="restart", child="rcl", supervisor="demo",
                                  reason="exit code 1"))
            await until(pilot, lambda: len(app.alerts.unacked()) == 4,
                        message="four alerts raised")
            await until(pilot, lambda: strip.plain.startswith("⚠ 4 new"), message="strip")
            assert "link down: ugv2" in strip.plain and "battery low: ugv1" in strip.plain
            assert strip.has_class("-new")
            log = app.query_one(LogPane)
            assert any("alert hotspot: hotspot_detected(h7" in line
                       for line in log.lines_text())
            await pilot.press("A")
            assert app.alerts.unacked() == [] and len(app.alerts.history()) == 4
            assert strip.plain.startswith("alerts: none new (4 in history")
            assert not strip.has_class("-new")
            # a recurrence raises it again
            peer.publish(SupEvent(event="restart", child="rcl", supervisor="demo"))
            await until(pilot, lambda: strip.plain.startswith("⚠ 1 new"), message="again")
            assert "restarted: demo/rcl ×2" in strip.plain
    run(body())


def test_help_lists_every_key_of_the_app_and_the_focused_panel(
        endpoints: BusEndpoints, peer: Peer) -> None:
    async def body() -> None:
        app = make_app(endpoints, world_every=0.0)
        async with app.run_test(size=SIZE) as pilot:
            app.query_one(MapPanel).focus()
            await pilot.press("question_mark")
            assert isinstance(app.screen, HelpScreen)
            rows = {(k.where, k.does) for k in app.screen.keys}
            for binding in MrssApp.BINDINGS + MapPanel.BINDINGS:
                assert any(does == binding.description  # type: ignore[union-attr]
                           for _, does in rows), binding
            assert ("map", "Follow robot") in rows and ("anywhere", "Ack alerts") in rows
            assert not any(does == "Teleop on/off" for _, does in rows)  # not focused
            mine = [k.own for k in app.screen.keys if k.where == "map"]
            assert mine[0] and mine == sorted(mine, reverse=True)  # its commands first
            await pilot.press("z")  # any key closes it, and does nothing else
            assert not isinstance(app.screen, HelpScreen)
            await pilot.press("f1")
            assert isinstance(app.screen, HelpScreen)
            await pilot.press("escape")
            assert not isinstance(app.screen, HelpScreen)
    run(body())


def hits(app: MrssApp) -> list[str]:
    """The command palette's hits shown now."""
    if not isinstance(app.screen, CommandPalette):
        return []
    options = app.screen.query_one(CommandList)
    return [str(options.get_option_at_index(i).prompt) for i in range(options.option_count)]


def test_palette_follows_a_robot_and_sends_a_percept(endpoints: BusEndpoints,
                                                    peer: Peer) -> None:
    async def body() -> None:
        app = make_app(endpoints, world_every=0.0)
        async with app.run_test(size=SIZE) as pilot:
            await connected(pilot, peer)
            peer.publish(position("uav1", -35.36, 149.16, 0.0), src="telemetry")
            await until(pilot, lambda: "uav1" in app.map_model.robots, message="uav1")
            await pilot.press("ctrl+p")
            await pilot.press(*"follow uav1")
            await until(pilot, lambda: hits(app),
                        message="palette hits")
            await pilot.press("enter")
            await until(pilot, lambda: app.query_one(MapPanel).following == "uav1",
                        message="the map follows uav1")
            await pilot.press("ctrl+p")
            await pilot.press(*"percept fire(area9)")
            await until(pilot, lambda: hits(app),
                        message="palette hits")
            await pilot.press("enter")
            await until(pilot, lambda: [p.literal for p in peer.received(Percept)]
                        == ["fire(area9)"], message="the percept on the bus")
    run(body())


def test_a_readonly_palette_refuses_to_send_a_percept(endpoints: BusEndpoints,
                                                     peer: Peer) -> None:
    async def body() -> None:
        app = make_app(endpoints, world_every=0.0, readonly=True)
        async with app.run_test(size=SIZE) as pilot:
            await connected(pilot, peer)
            await pilot.press("ctrl+p")
            await pilot.press(*"percept fire(area9)")
            await until(pilot, lambda: hits(app), message="palette hits")
            await pilot.press("enter")
            log = app.query_one(LogPane)
            await until(pilot, lambda: any("percept add fire(area9) refused: read-only" in line
                                           for line in log.lines_text()), message="refused")
            peer.publish(Percept(literal="marker(1)"), src="tui")  # shows what did arrive
            await until(pilot, lambda: peer.received(Percept), message="the marker")
            assert [p.literal for p in peer.received(Percept)] == ["marker(1)"]
    run(body())


def test_a_world_model_error_shows_on_the_map_title(endpoints: BusEndpoints,
                                                    peer: Peer) -> None:
    async def body() -> None:
        app = make_app(endpoints, world_every=0.0)
        async with app.run_test(size=SIZE) as pilot:
            await connected(pilot, peer)
            panel = app.query_one(MapPanel)
            with Publisher(endpoints, src="worldmodel") as pub:
                assert pub.wait_connected(10)
                # another requester's reply (on its own topic, or the shared one): ignored
                pub.publish(DataReply(request_id="someone-else", ok=False, error="not ours"),
                            topic=wm_reply_topic("tui"))
                pub.publish(DataReply(request_id="tui-wm-0", ok=False, error="not for us"),
                            topic=wm_reply_topic("datalayer"))
                pub.publish(DataReply(request_id="tui-wm-1", ok=False,
                                      error="WorldStoreUnavailable: db down"),
                            topic=wm_reply_topic("tui"))
                pub.flush()
            await until(pilot, lambda: "world model: WorldStoreUnavailable: db down"
                        in str(panel.border_title), message="the error on the title")
            assert "not ours" not in str(panel.border_title)
            assert "not for us" not in str(panel.border_title)
            assert WM_REPLY_TOPIC + ".datalayer" not in app.topics.topics  # not subscribed
    run(body())
