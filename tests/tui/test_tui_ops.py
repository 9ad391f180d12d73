"""The operator's extra views in the running app (Textual pilot, a real proxy and peer):
the Messages screen (M), one log line in full (L), the alerts list with per-alert
acknowledgement (!), and the palette's add a goal and bus recording, refused read-only."""

from __future__ import annotations

import json
from pathlib import Path
from typing import Any

import pytest
from textual.app import App
from textual.widgets import Input, Tree

from mrss.bus import BusEndpoints
from mrss.bus.wire import message_frames
from mrss.config.operator import read_operator
from mrss.messages import LogRecord, RobotData, decode
from mrss.recording.files import recorded_messages
from mrss.recording.format import RecordingError
from mrss.tui.app import MrssApp
from mrss.tui.area_form import AreaForm
from mrss.tui.mission import MissionChannel, run_dir_of
from mrss.tui.palette import MrssCommands
from mrss.tui.widgets.alerts_list import AlertsScreen
from mrss.tui.widgets.alerts_strip import AlertsStrip
from mrss.tui.widgets.log_lines import LogLinesScreen
from mrss.tui.widgets.log_pane import LogPane
from mrss.tui.widgets.messages_view import MessagesScreen
from mrss.tui.widgets.operator_bar import OperatorBar
from tests.tui.test_tui_map_alerts import hits
from tests.tui.tui_helpers import Peer, connected, run, until

SIZE = (160, 45)
RULES = ({"name": "water low", "field": "tank.level", "below": 50},)


def make_app(endpoints: BusEndpoints, **kw: Any) -> MrssApp:
    return MrssApp(endpoints, project="demo", mind_every=0, tree_every=0, world_every=0, **kw)


def tank(robot: str, level: float) -> RobotData:
    return RobotData(robot=robot, data={"type": "tank", "level": level, "capacity": 200.0})


async def palette(pilot: Any, app: MrssApp, text: str, name: str) -> None:
    """Type `text` into the palette, then run its first hit, which must be `name`."""
    await pilot.press("ctrl+p")
    await pilot.press(*text)
    shown = await until(pilot, lambda: hits(app), message=f"palette hits for {text!r}")
    assert shown[0].startswith(name), shown
    await pilot.press("enter")


def test_messages_screen_shows_topics_as_a_tree_with_the_latest_json_and_history(
        endpoints: BusEndpoints, peer: Peer) -> None:
    async def body() -> None:
        app = make_app(endpoints)
        async with app.run_test(size=SIZE) as pilot:
            await connected(pilot, peer)
            for level in (150.0, 140.0, 130.0):
                peer.publish(tank("ugv1", level), src="rcl")
            peer.publish(LogRecord(component="rcl", level="INFO", message="hello"), src="rcl")
            await until(pilot, lambda: "robot.ugv1.data" in app.topics.topics
                        and app.topics.topics["robot.ugv1.data"].count == 3
                        and "log.rcl" in app.topics.topics, message="counted in the drain")
            await pilot.press("M")
            screen = await until(pilot, lambda: isinstance(app.screen, MessagesScreen)
                                 and app.screen, message="the Messages screen")
            tree: Tree[str] = screen.query_one(Tree)
            labels = {str(n.data): str(n.label) for n in _nodes(tree.root)}
            assert labels["robot"].startswith("robot  3 · ")  # a level sums its topics
            assert labels["robot.ugv1"].startswith("ugv1  3 · ")
            assert labels["robot.ugv1.data"].startswith("data  3 · ")
            assert labels["log.rcl"].startswith("rcl  1 · ")
            # arrows move through the tree: the right side follows the cursor
            assert screen.select_topic("robot.ugv1.data")
            latest = json.loads(screen.latest_text)
            assert (latest["kind"], latest["src"], latest["body"]["data"]["level"]) == \
                ("robot.data", "rcl", 130.0)
            assert len(screen.history_text) == 3
            assert ['"level":130.0' in screen.history_text[0],
                    '"level":150.0' in screen.history_text[2]] == [True, True]
            # a new topic above it in the tree: the cursor stays on the chosen topic
            peer.publish(LogRecord(component="aaa", level="INFO", message="new"), src="aaa")
            await until(pilot, lambda: "log.aaa" in screen._topic_nodes, message="log.aaa")
            await pilot.pause()
            assert screen.topic == "robot.ugv1.data"
            assert tree.cursor_node is not None and tree.cursor_node.data == "robot.ugv1.data"
            await pilot.press("up")  # to robot > ugv1: a level, no message
            await until(pilot, lambda: screen.topic == "robot.ugv1", message="the level")
            assert screen.latest_text == "" and screen.history_text == []
            # live: a new message shows within the screen's next redraw
            peer.publish(tank("ugv1", 120.0), src="rcl")
            await pilot.press("down")
            await until(pilot, lambda: screen.topic == "robot.ugv1.data"
                        and '"level": 120.0' in screen.latest_text, message="the new message")
            await pilot.press("escape")
            await until(pilot, lambda: not isinstance(app.screen, MessagesScreen),
                        message="closed")
    run(body())


def _nodes(node: Any) -> list[Any]:
    out = [node]
    for child in node.children:
        out.extend(_nodes(child))
    return out


def test_log_lines_screen_shows_one_long_line_whole(endpoints: BusEndpoints,
                                                    peer: Peer) -> None:
    async def body() -> None:
        app = make_app(endpoints)
        long = "disk full " + "x" * 400 + " END"
        async with app.run_test(size=SIZE) as pilot:
            await connected(pilot, peer)
            peer.publish(LogRecord(component="rcl", level="WARNING", message=long), src="rcl")
            peer.publish(LogRecord(component="reasoner", level="INFO", message="short"),
                         src="reasoner")
            log = app.query_one(LogPane)
            await until(pilot, lambda: any("short" in line for line in log.lines_text()),
                        message="both lines in the log")
            await pilot.press("L")
            screen = await until(pilot, lambda: isinstance(app.screen, LogLinesScreen)
                                 and app.screen, message="the log lines screen")
            await until(pilot, lambda: "short" in screen.shown, message="the newest line")
            await pilot.press("up", "enter")
            await until(pilot, lambda: "END" in screen.shown, message="the long line")
            assert long in screen.shown.replace("\n", "")
            assert "level     WARNING" in screen.shown and "component rcl" in screen.shown
            await pilot.press("escape")
            await until(pilot, lambda: not isinstance(app.screen, LogLinesScreen),
                        message="closed")
    run(body())


def test_alerts_list_acknowledges_one_alert_and_A_all(endpoints: BusEndpoints,
                                                      peer: Peer) -> None:
    from mrss.config.alerts import read_alert_rules

    async def body() -> None:
        app = make_app(endpoints, alert_rules=read_alert_rules(list(RULES)))
        async with app.run_test(size=SIZE) as pilot:
            await connected(pilot, peer)
            peer.publish(tank("ugv1", 40.0), src="rcl")
            peer.publish(tank("ugv2", 30.0), src="rcl")
            strip = app.query_one(AlertsStrip)
            await until(pilot, lambda: "2 new" in strip.plain, message="two rule alerts")
            assert "water low: ugv2 tank.level 30 < 50" in strip.plain
            await pilot.press("exclamation_mark")
            screen = await until(pilot, lambda: isinstance(app.screen, AlertsScreen)
                                 and app.screen, message="the alerts list")
            selected = screen.selected()
            assert selected is not None and selected.subject == "ugv2"  # newest first
            await pilot.press("enter")
            await until(pilot, lambda: "1 new" in strip.plain, message="one acknowledged")
            assert [a.subject for a in app.alerts.unacked()] == ["ugv1"]
            bar = app.query_one(OperatorBar)
            assert "acknowledged water low: ugv2" in bar.status_text
            await pilot.press("A")
            await until(pilot, lambda: "none new" in strip.plain, message="all acknowledged")
            await pilot.press("escape")
            await until(pilot, lambda: not isinstance(app.screen, AlertsScreen),
                        message="closed")
    run(body())


def test_palette_adds_a_goal_through_the_area_form_refused_readonly_or_undeclared(
        endpoints: BusEndpoints) -> None:
    async def body() -> None:
        channel = MissionChannel(read_operator({"area": "ops/area"}), lambda: None)
        app = make_app(endpoints, mission=channel)
        async with app.run_test(size=SIZE) as pilot:
            await palette(pilot, app, "goal", "Add a goal (area)")
            form = await until(pilot, lambda: isinstance(app.screen, AreaForm) and app.screen,
                               message="the area form")
            form.query_one("#area-name", Input).value = "north"
            form.query_one("#area-center", Input).value = "-35.36,149.16"
            await pilot.press("ctrl+s")
            # the form sends through the mission channel: here it has no broker
            bar = app.query_one(OperatorBar)
            await until(pilot, lambda: "no MQTT broker known" in bar.status_text,
                        message="sent to the mission channel")
            assert "area north (priority 1)" in bar.status_text
        # the palette's command is `add_goal`: refused read-only, or with no area command
        for kw, expected in (({"mission": channel, "readonly": True}, "read-only"),
                             ({}, "declares no area command")):
            app = make_app(endpoints, **kw)
            async with app.run_test(size=SIZE) as pilot:
                app.add_goal()
                bar = app.query_one(OperatorBar)
                await until(pilot, lambda b=bar, e=expected: e in b.status_text,  # type: ignore[misc]
                            message=expected)
                assert bar.status_error and not isinstance(app.screen, AreaForm)
    run(body())


def recorded_topics(path: Path) -> list[str]:
    """The topics in a recording so far (a last entry being written is left out)."""
    topics: list[str] = []
    with path.open("rb") as handle:
        try:
            for message in recorded_messages(handle):
                topics += [decode(t, p).topic for t, p in message_frames(list(message.frames))]
        except RecordingError:
            pass
    return topics


def test_palette_records_the_bus_into_the_run_dir_and_stops(endpoints: BusEndpoints,
                                                           peer: Peer) -> None:
    async def body() -> None:
        run_dir = run_dir_of(endpoints.backend)
        assert run_dir is not None
        app = make_app(endpoints)
        async with app.run_test(size=SIZE) as pilot:
            await connected(pilot, peer)
            await palette(pilot, app, "record", "Start recording")
            await until(pilot, lambda: app.recording is not None
                        and app.recording.started.is_set(), message="recording")
            recording = app.recording
            assert recording is not None and not recording.error
            assert recording.path.parent == run_dir

            def probed() -> bool:  # the recorder's subscription has reached the proxy
                peer.publish(tank("probe", 1.0), src="rcl")
                return "robot.probe.data" in recorded_topics(recording.path)

            await until(pilot, probed, message="a probe recorded")
            for level in (10.0, 20.0):
                peer.publish(tank("ugv9", level), src="rcl")
            await until(pilot, lambda: recorded_topics(recording.path)
                        .count("robot.ugv9.data") == 2, message="both recorded")
            names = [name for name, _, _ in MrssCommands(app.screen)._commands("")]
            assert "Stop recording" in names and "Start recording" not in names
            app.toggle_recording()  # the palette's "Stop recording"
            bar = app.query_one(OperatorBar)
            await until(pilot, lambda: "recorded" in bar.status_text, message="stopped")
            assert str(recording.path) in bar.status_text and app.recording is None
            assert f"recorded {recording.count} messages" in bar.status_text
        topics = recorded_topics(recording.path)
        assert topics.count("robot.ugv9.data") == 2
        assert len(topics) >= recording.count  # an entry may be a publisher's batch
    run(body())


def test_a_recording_that_cannot_start_says_why(tmp_path: Path,
                                                monkeypatch: pytest.MonkeyPatch) -> None:
    from mrss.tui import ops, recorder

    monkeypatch.setattr(recorder, "CONNECT_TIMEOUT", 0.2)
    monkeypatch.setattr(ops, "CONNECT_TIMEOUT", 0.2)

    async def body() -> None:
        app = make_app(BusEndpoints.ipc(tmp_path))  # no proxy there
        async with app.run_test(size=SIZE) as pilot:
            app.toggle_recording()
            bar = app.query_one(OperatorBar)
            await until(pilot, lambda: "recording failed: no bus proxy answered" in
                        bar.status_text, message="the failure")
            assert bar.status_error and app.recording is None
        assert not list(tmp_path.glob("*.mcap"))
    run(body())


def test_a_readonly_dashboard_refuses_to_record(endpoints: BusEndpoints) -> None:
    async def body() -> None:
        app = make_app(endpoints, readonly=True)
        async with app.run_test(size=SIZE) as pilot:
            app.toggle_recording()  # the palette's "Start recording"
            bar = app.query_one(OperatorBar)
            await until(pilot, lambda: "recording refused: read-only" in bar.status_text,
                        message="refused")
            assert app.recording is None
        run_dir = run_dir_of(endpoints.backend)
        assert run_dir is not None and not list(Path(run_dir).glob("*.mcap"))
    run(body())


def test_the_area_form_keeps_the_cursor_on_a_bad_field_and_says_why() -> None:
    class Host(App[None]):
        result: dict[str, Any] | None = None

        def on_mount(self) -> None:
            self.push_screen(AreaForm(), self._answer)

        def _answer(self, payload: dict[str, Any] | None) -> None:
            self.result = payload

    async def body() -> None:
        app = Host()
        async with app.run_test(size=(80, 24)) as pilot:
            form = app.screen
            assert isinstance(form, AreaForm)

            def focused() -> str:
                return app.focused.id if app.focused is not None else ""

            await pilot.press(*"North", "enter")  # not an id: Enter does not move on
            assert focused() == "area-name" and "lowercase identifier" in form.error
            form.query_one("#area-name", Input).value = "north"
            await pilot.press("enter")
            assert focused() == "area-center" and form.error == ""
            await pilot.press(*"north", "enter")
            assert focused() == "area-center" and "centre must be LAT,LON" in form.error
            form.query_one("#area-center", Input).value = "47.07,15.43"
            form.query_one("#area-radius", Input).value = "-3"
            await pilot.press("ctrl+s")  # sending checks all: the radius gets the cursor
            assert focused() == "area-radius" and "more than 0 m" in form.error
            assert isinstance(app.screen, AreaForm)
            form.query_one("#area-radius", Input).value = "80"
            await pilot.press("enter", "enter")  # radius, then priority: sent
            await until(pilot, lambda: app.result is not None, message="the area sent")
        assert app.result == {"goal": "north", "center": [47.07, 15.43], "radius": 80.0,
                              "priority": 1}

    run(body())
