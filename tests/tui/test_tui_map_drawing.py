"""Pointing and drawing on the map: the cursor, vertices by key, a point, circle or
polygon that opens a declared command's form pre-filled; a polygon that crosses itself
and one with 10,000 vertices refused with the reason (nothing opens); robots at one spot
readable (`uav1+1`, and `l` lists them); an area's state next to its name."""

from __future__ import annotations

from typing import Any

import pytest
from textual.widgets import Input

from mrss.bus import BusEndpoints
from mrss.config.map import read_map
from mrss.config.operator import read_operator
from mrss.config.operator_commands import CommandError, FieldSpec, FieldType
from mrss.messages import Command, RobotData, StandDownMode, StandDownState
from mrss.tui import stand_down
from mrss.tui.app import MrssApp
from mrss.tui.command_form import CommandForm, CommandMenu
from mrss.tui.confirm import ConfirmScreen
from mrss.tui.mission import MissionChannel
from mrss.tui.models.geo import Viewport
from mrss.tui.models.map import MapModel
from mrss.tui.models.sketch import Sketch, SketchError
from mrss.tui.widgets.map_panel import MapPanel
from mrss.tui.widgets.operator_bar import OperatorBar
from tests.tui.tui_helpers import Peer, run, until

COMMANDS = {"commands": {
    "exclusion": {"label": "Exclusion zone", "percept": "exclusion_zone(Zone, Shape)",
                  "fields": [{"name": "zone", "type": "text", "atom": True, "default": "x1"},
                             {"name": "shape", "type": "polygon", "max_vertices": 50}]},
    "sample": {"label": "Sample here", "percept": "sample_at(Where)",
               "fields": [{"name": "where", "type": "point"}]},
    "watch": {"label": "Watch a ring", "percept": "watch(Ring)",
              "fields": [{"name": "ring", "type": "circle", "min": 1, "max": 5000,
                          "units": "m"}]},
    "survey": {"label": "Survey a ring", "percept": "survey(Ring)",
               "fields": [{"name": "ring", "type": "circle"}]},
}}
BASE = (47.07, 15.43)


def _app(endpoints: BusEndpoints) -> MrssApp:
    channel = MissionChannel(read_operator(COMMANDS), lambda: None)
    return MrssApp(endpoints, project="drawing", mind_every=0, tree_every=0, mission=channel)


def _place(app: MrssApp, robot: str, lat: float, lon: float) -> None:
    data = RobotData(robot=robot, data={"lat": lat, "lon": lon})
    app.map_model.apply_data(data)
    app.robots.apply_data(data, 0.0)


def _status(app: MrssApp) -> str:
    return str(app.query_one(OperatorBar).status_text)


async def _map(pilot: Any, app: MrssApp) -> MapPanel:
    panel = app.query_one(MapPanel)
    panel.focus()
    await pilot.pause()
    return panel


def test_a_polygon_drawn_by_keys_opens_the_zone_form_pre_filled(
        endpoints: BusEndpoints) -> None:
    async def body() -> None:
        app = _app(endpoints)
        async with app.run_test(size=(160, 45)) as pilot:
            _place(app, "uav1", *BASE)
            _place(app, "ugv1", BASE[0] + 0.004, BASE[1] + 0.004)
            panel = await _map(pilot, app)
            panel.refresh()
            await pilot.press("space")  # the cursor, at the centre of the view
            assert panel.sketch.cursor is not None
            await pilot.press("enter", *["right"] * 6, "enter", *["down"] * 4, "enter")
            assert len(panel.sketch.vertices) == 3
            assert "3 vertices" in str(panel.border_title)
            await pilot.press("Z")  # the project's command, or a stand-down by area
            menu = await until(pilot, lambda: isinstance(app.screen, CommandMenu)
                               and app.screen, 10, "the menu of area commands")
            assert [name for name, _ in menu.choices] == ["exclusion", stand_down.NAME]
            await pilot.press("enter")
            form = await until(pilot, lambda: isinstance(app.screen, CommandForm)
                               and app.screen, 10, "the zone form")
            assert form.spec.name == "exclusion"
            text = form.query_one("#cmd-shape", Input).value
            assert text == panel.sketch.polygon() and text.count(";") == 2
            await pilot.press("ctrl+s")  # the form checks it again: good, it would send
            await until(pilot, lambda: not isinstance(app.screen, CommandForm), 10)
            assert "exclusion" in _status(app)
    run(body())


def test_a_polygon_that_crosses_itself_is_refused_and_nothing_opens(
        endpoints: BusEndpoints) -> None:
    async def body() -> None:
        app = _app(endpoints)
        async with app.run_test(size=(160, 45)) as pilot:
            _place(app, "uav1", *BASE)
            _place(app, "ugv1", BASE[0] + 0.004, BASE[1] + 0.004)
            panel = await _map(pilot, app)
            # a bow tie: top-left, bottom-right, top-right, bottom-left
            await pilot.press("space", "enter", *["right"] * 6, *["down"] * 4, "enter",
                              *["up"] * 4, "enter", *["left"] * 6, *["down"] * 4, "enter")
            assert len(panel.sketch.vertices) == 4
            await pilot.press("Z")
            await until(pilot, lambda: "not a polygon" in _status(app), 10, "the refusal")
            assert "crosses itself" in _status(app)
            assert not isinstance(app.screen, CommandForm)
            assert len(panel.sketch.vertices) == 4  # kept, to mend with Backspace
            await pilot.press("backspace")
            assert len(panel.sketch.vertices) == 3
    run(body())


def test_a_point_and_a_circle_pre_fill_their_forms(endpoints: BusEndpoints) -> None:
    async def body() -> None:
        app = _app(endpoints)
        async with app.run_test(size=(160, 45)) as pilot:
            _place(app, "uav1", *BASE)
            _place(app, "ugv1", BASE[0] + 0.004, BASE[1] + 0.004)
            panel = await _map(pilot, app)
            await pilot.press("space", "P")  # one command takes a point: its form at once
            form = await until(pilot, lambda: isinstance(app.screen, CommandForm)
                               and app.screen, 10, "the sample form")
            lat, lon = (float(v) for v in form.query_one("#cmd-where", Input).value.split(","))
            assert panel.sketch.cursor == pytest.approx((lat, lon), abs=1e-6)
            await pilot.press("escape")
            await until(pilot, lambda: not isinstance(app.screen, CommandForm), 10)

            await pilot.press("enter", *["right"] * 5, "R")  # two take a circle: a menu
            menu = await until(pilot, lambda: isinstance(app.screen, CommandMenu)
                               and app.screen, 10, "the menu of circle commands")
            assert [name for name, _ in menu.choices] == ["watch", "survey", stand_down.NAME]
            await pilot.press("enter")
            form = await until(pilot, lambda: isinstance(app.screen, CommandForm)
                               and app.screen, 10, "the watch form")
            text = form.query_one("#cmd-ring", Input).value
            assert text == panel.sketch.circle() and float(text.split(",")[2]) > 0
    run(body())


def test_an_area_drawn_stands_down_the_robots_inside_after_a_question_naming_them(
        endpoints: BusEndpoints) -> None:
    peer = Peer(endpoints)

    async def body() -> None:
        app = _app(endpoints)
        async with app.run_test(size=(160, 45)) as pilot:
            _place(app, "uav1", *BASE)
            _place(app, "ugv1", BASE[0] + 0.004, BASE[1] + 0.004)
            _place(app, "uav2", BASE[0] + 0.002, BASE[1] + 0.002)  # the view's centre
            panel = await _map(pilot, app)
            panel.refresh()
            # a square of 8 x 6 cells around the cursor at the centre of the view
            await pilot.press("space", *["left"] * 4, *["up"] * 3, "enter", *["right"] * 8,
                              "enter", *["down"] * 6, "enter", *["left"] * 8, "enter", "Z")
            await until(pilot, lambda: isinstance(app.screen, CommandMenu), 10, "the menu")
            await pilot.press("down", "enter")
            form = await until(pilot, lambda: isinstance(app.screen, CommandForm)
                               and app.screen.query("#cmd-area") and app.screen, 10,
                               "the stand-down form")
            assert form.query_one("#cmd-area", Input).value == panel.sketch.polygon()
            form.query_one("#cmd-mode", Input).value = "hme"  # a typo: named, nothing sent
            await pilot.press("ctrl+s")
            await until(pilot, lambda: "'hme' is not one of hold, home" in form.error, 10,
                        "the refusal")
            form.query_one("#cmd-mode", Input).value = "home"
            await pilot.press("ctrl+s")
            question = await until(pilot, lambda: isinstance(app.screen, ConfirmScreen)
                                   and app.screen, 10, "the question")
            assert question.question == "Stand down every robot in this area (home)?"
            outline = stand_down.ring(FieldSpec("a", FieldType.POLYGON).from_text(
                panel.sketch.polygon()), FieldType.POLYGON)
            inside = stand_down.inside(app.robots, outline)
            assert inside == ["uav2"]
            assert f"seen inside here: {', '.join(inside)} " in question.details[1]
            await pilot.press("y")
            sent = await until(pilot, lambda: [c for c in peer.received(Command)
                                               if c.command == "stand_down"], 10, "sent")
            args = sent[0].args
            assert (args["mode"], args["capabilities"], args["robots"]) == ("home", [], inside)
            assert args["area"] == {"type": "Polygon", "coordinates": [outline]}
            # the RCL's answer: on the map and in the log; U lifts it after a question
            app.map_model.apply_stand_down(StandDownState(
                ident=sent[0].target, mode=StandDownMode.HOME, active=True,
                area=args["area"], robots=inside))
            await pilot.press("escape", "U")
            await until(pilot, lambda: isinstance(app.screen, ConfirmScreen), 10, "lift?")
            await pilot.press("y")
            await until(pilot, lambda: [c for c in peer.received(Command)
                                        if c.command == "stand_down_lift"], 10, "lift sent")
    try:
        run(body())
    finally:
        peer.close()


def test_robots_at_one_spot_stay_readable(endpoints: BusEndpoints) -> None:
    async def body() -> None:
        app = _app(endpoints)
        async with app.run_test(size=(160, 45)) as pilot:
            for robot in ("uav1", "uav2", "uav3"):
                _place(app, robot, *BASE)
            _place(app, "ugv1", BASE[0] + 0.004, BASE[1] + 0.004)
            panel = await _map(pilot, app)
            panel.refresh()
            await until(pilot, lambda: "uav1+2" in str(panel.render()), 10, "uav1+2")
            await pilot.press("l")  # no cursor: the busiest spot
            await until(pilot, lambda: "3 robots" in _status(app), 10)
            assert "uav1, uav2, uav3" in _status(app)
    run(body())


def test_ten_thousand_vertices_are_refused_with_the_limit() -> None:
    sketch = Sketch(cursor=BASE, vertices=[(BASE[0] + i * 1e-5, BASE[1]) for i in range(10_000)])
    with pytest.raises(SketchError, match="10000 vertices, at most 1000"):
        sketch.polygon()
    with pytest.raises(SketchError, match="at most 1000 vertices"):
        sketch.add()
    field = FieldSpec(name="shape", type=FieldType.POLYGON, max_vertices=50)
    text = "; ".join(f"{BASE[0] + i * 1e-5},{BASE[1]}" for i in range(10_000))
    with pytest.raises(CommandError, match="shape: 10000 vertices, at most 50"):
        field.from_text(text)


def test_an_area_shows_its_state_next_to_its_name() -> None:
    model = MapModel(read_map({"kinds": {"zone": {"state_field": "state",
                                                  "states": {"lifted": "dim"}}}}))
    ring = [[15.43, 47.07], [15.44, 47.07], [15.44, 47.08], [15.43, 47.07]]
    model.apply_world([
        {"id": "x1", "kind": "zone", "attributes": {"state": "active"},
         "geometry": {"type": "Polygon", "coordinates": [ring]}},
        {"id": "x2", "kind": "zone", "attributes": {"state": "lifted"},
         "geometry": {"type": "Polygon", "coordinates": [[[p[0] + 0.02, p[1]] for p in ring]]}},
    ])
    view = Viewport()
    view.fit(model.points(), 60, 20)
    text = "\n".join("".join(run for run, _ in row) for row in model.draw(view, 60, 20).rows())
    assert "x1 active" in text and "x2 lifted" in text
