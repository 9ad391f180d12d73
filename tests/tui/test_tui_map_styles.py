"""The map's plans (lanes done and left) and the project's `[map]` styles: the pure model,
the table's checks (`read_map`, `mrss check`), and the running app (Textual pilot, a real
proxy, a real world model answering `wm.list`)."""

from __future__ import annotations

import shutil
from pathlib import Path
from typing import Any

import pytest

from mrss.bus import BusEndpoints
from mrss.check import check_project
from mrss.config.loader import load_file
from mrss.config.map import MapConfig, PolygonDraw, read_map
from mrss.errors import ConfigError
from mrss.messages import ActionStatus, RobotData
from mrss.messages.plans import PLAN_MAX_WAYPOINTS, clear_record, plan_record
from mrss.tui.app import MrssApp
from mrss.tui.models.braille import BrailleCanvas
from mrss.tui.models.geo import Viewport
from mrss.tui.models.map import MapModel
from mrss.tui.widgets.map_panel import MapPanel
from mrss.world.objects import WorldObject
from tests.tui.conftest import HERE
from tests.tui.test_tui_map_alerts import WorldService, world  # noqa: F401 - the fixture
from tests.tui.tui_helpers import Peer, connected, run, until

W, H = 40, 12
TUIMAP = HERE / "tuimap" / "project.toml"
# a lawnmower of three lanes, 1 km each, around (47.07, 15.43)
LANES = [[47.060, 15.420], [47.060, 15.440], [47.065, 15.440], [47.065, 15.420],
         [47.070, 15.420], [47.070, 15.440]]


def data(robot: str, **record: Any) -> RobotData:
    return RobotData(robot=robot, data=record)


def cell_styles(canvas: BrailleCanvas) -> list[list[str]]:
    out = []
    for runs in canvas.rows():
        row: list[str] = []
        for text, style in runs:
            row.extend([style] * len(text))
        out.append(row)
    return out


def segment_style(canvas: BrailleCanvas, view: Viewport, a: list[float],
                  b: list[float]) -> str:
    col, row = view.to_cell((a[0] + b[0]) / 2, (a[1] + b[1]) / 2, W, H)
    return cell_styles(canvas)[row][col]


def test_a_plan_draws_the_lanes_flown_dim_and_those_left_bright() -> None:
    model = MapModel()
    assert model.apply_data(data("uav1", type="position", lat=47.065, lon=15.430))
    assert model.apply_data(data("uav1", **plan_record("a1", LANES, 3, "area1")))
    view = Viewport(lat=47.065, lon=15.430, scale=40.0)
    canvas = model.draw(view, W, H)
    # uav1 is the first robot: cyan; lanes 0-1 and 1-2 flown (dim), 3-4 and 4-5 left
    assert segment_style(canvas, view, LANES[0], LANES[1]) == "dim cyan"
    assert segment_style(canvas, view, LANES[1], LANES[2]) == "dim cyan"
    assert segment_style(canvas, view, LANES[3], LANES[4]) == "bold cyan"
    assert segment_style(canvas, view, LANES[4], LANES[5]) == "bold cyan"
    # the plan's waypoints count when the view fits everything
    assert (47.060, 15.420) in model.points()
    # two waypoints reached: lane 3-4 is flown now, the rest starts at the robot
    assert model.apply_data(data("uav1", type="position", lat=47.070, lon=15.420))
    assert model.apply_data(data("uav1", **plan_record("a1", LANES, 5, "area1")))
    canvas = model.draw(view, W, H)
    assert segment_style(canvas, view, LANES[3], LANES[4]) == "dim cyan"
    assert segment_style(canvas, view, LANES[4], LANES[5]) == "bold cyan"
    # the end of another action's plan leaves this one; the end of its own clears it
    assert not model.apply_data(data("uav1", **clear_record("other")))
    assert model.plans["uav1"].next == 5
    assert model.apply_data(data("uav1", **clear_record("a1")))
    assert "uav1" not in model.plans
    canvas = model.draw(view, W, H)
    assert segment_style(canvas, view, LANES[0], LANES[1]) == ""  # nothing drawn there


def test_the_end_of_its_action_takes_a_plan_off_the_map() -> None:
    model = MapModel()
    model.apply_data(data("uav1", **plan_record("a1", LANES, 0)))
    model.apply_data(data("ugv1", **plan_record("a2", LANES[:2], 0)))
    assert not model.apply_status(ActionStatus(uuid="a1", state="running", robot="uav1"))
    assert not model.apply_status(ActionStatus(uuid="a9", state="failed", robot="uav1"))
    assert model.apply_status(ActionStatus(uuid="a1", state="cancelled", robot="uav1"))
    assert list(model.plans) == ["ugv1"]


def test_bad_plan_records_are_ignored_without_an_exception() -> None:
    model = MapModel()
    good = plan_record("a1", LANES, 1)
    model.apply_data(data("uav1", **good))
    bad: list[dict[str, Any]] = [
        {**good, "waypoints": "north"}, {**good, "waypoints": [[47.0]]},
        {**good, "waypoints": [[47.0, "east"]]}, {**good, "waypoints": [[95.0, 15.0]]},
        {**good, "waypoints": [[float("nan"), 15.0]]}, {**good, "waypoints": [None]},
        {**good, "waypoints": [[47.0, 15.0]] * (PLAN_MAX_WAYPOINTS + 1)},
        {**good, "next": 7}, {**good, "next": -1}, {**good, "next": True},
        {**good, "next": 1.5}, {**good, "action": 3}, {"type": "plan"},
    ]
    for record in bad:
        assert not model.apply_data(data("uav1", **record)), record
    assert model.plans["uav1"].waypoints[0] == (47.060, 15.420)  # the good one stays
    model.draw(Viewport(lat=47.065, lon=15.43, scale=40.0), W, H)


def test_plan_record_thins_a_long_plan_and_keeps_its_end() -> None:
    long = [[47.0 + i * 1e-5, 15.0] for i in range(1000)]
    record = plan_record("a1", long, 500, "g")
    points = record["waypoints"]
    assert isinstance(points, list) and len(points) <= PLAN_MAX_WAYPOINTS
    assert points[-1] == long[-1] and points[0] == long[0]
    assert record["next"] == 125 and record["goal"] == "g"  # every 4th kept: 500 / 4


def test_objects_are_styled_by_kind_and_state_and_hidden_kinds_are_not_drawn() -> None:
    styles = read_map(load_file(TUIMAP).sections["map"], file=str(TUIMAP))
    model = MapModel(styles)
    model.apply_world([
        {"id": "h1", "kind": "hotspot", "position": {"lat": 47.062, "lon": 15.425}},
        {"id": "h2", "kind": "hotspot", "position": {"lat": 47.068, "lon": 15.435},
         "attributes": {"state": "dealt"}},
        {"id": "h3", "kind": "hotspot", "position": {"lat": 47.062, "lon": 15.435},
         "attributes": {"state": "unheard_of"}},
        {"id": "ugv1", "kind": "robot", "position": {"lat": 47.066, "lon": 15.431}},
        {"id": "zone", "kind": "area", "geometry": {"type": "Polygon", "coordinates": [[
            [15.426, 47.063], [15.434, 47.063], [15.434, 47.067], [15.426, 47.067]]]}},
    ])
    assert "ugv1" not in model.objects  # kind robot hidden
    view = Viewport(lat=47.065, lon=15.430, scale=40.0)
    canvas = model.draw(view, W, H)
    grid = cell_styles(canvas)

    def look(lat: float, lon: float) -> tuple[str, str]:
        col, row = view.to_cell(lat, lon, W, H)
        return canvas.text()[row][col], grid[row][col]

    assert look(47.062, 15.425) == ("✹", "bold red")  # no state: the kind's style
    assert look(47.068, 15.435) == ("✹", "green")  # dealt
    assert look(47.062, 15.435) == ("✹", "bold red")  # an unknown state: the kind's style
    # the area is filled: dots inside it, in its style
    char, style = look(47.065, 15.430)
    assert ord(char) > 0x2800 and style == "cyan"
    # without [map]: today's defaults, areas outlined (nothing inside)
    plain = MapModel()
    plain.apply_world([{"id": "zone", "kind": "area", "geometry": {
        "type": "Polygon", "coordinates": [[[15.426, 47.063], [15.434, 47.063],
                                             [15.434, 47.067], [15.426, 47.067]]]}},
        {"id": "h1", "kind": "hotspot", "position": {"lat": 47.062, "lon": 15.425}}])
    canvas = plain.draw(view, W, H)
    col, row = view.to_cell(47.065, 15.430, W, H)
    assert canvas.text()[row][col] == " "
    col, row = view.to_cell(47.067, 15.430, W, H)
    assert cell_styles(canvas)[row][col] == "yellow"


def test_the_map_table_is_read_and_its_mistakes_named() -> None:
    config = read_map({"hide": ["robot"], "kinds": {"no_go": {"style": "bold red",
                                                              "polygon": "fill"}}})
    assert config.hide == {"robot"} and config.kind("no_go").polygon is PolygonDraw.FILL
    assert read_map(None) == MapConfig()
    for table, problem in (
            ({"kinds": {"hotspot": {"colour": "red"}}}, "unknown key 'colour'"),
            ({"kinds": {"hotspot": {"syle": "red"}}}, "did you mean 'style'"),
            ({"kind": {}}, "did you mean 'kinds'"),
            ({"kinds": {"hotspot": {"style": "blod red"}}}, "not a style"),
            ({"kinds": {"hotspot": {"state_field": "state",
                                    "states": {"new": "reed"}}}}, "not a style"),
            ({"kinds": {"hotspot": {"states": {"new": "red"}}}}, "need a state_field"),
            ({"kinds": {"hotspot": {"glyph": "**"}}}, "one printable character"),
            ({"kinds": {"hotspot": {"glyph": "🔥"}}}, "one cell wide"),
            ({"kinds": {"zone": {"polygon": "filled"}}}, "'outline', 'fill'"),
            ({"kinds": {"zone": {"label": "no"}}}, "true or false"),
            ({"hide": "robot"}, "list of world-model kinds"),
            ({"kinds": {"zone": "red"}}, "must be a table"),
            ({"kinds": {"base": {"radius_field": ""}}}, "name of an attribute"),
            ({"kinds": {"base": {"radius_style": "cyann"}}}, "not a style"),
            ({"kinds": {"base": {"radius_feild": "r"}}}, "did you mean 'radius_field'")):
        with pytest.raises(ConfigError, match=problem):
            read_map(table, file="project.toml")


def test_mrss_check_names_a_bad_map_table_at_its_line(tmp_path: Path) -> None:
    project = tmp_path / "tuimap"
    shutil.copytree(HERE / "tuimap", project)
    toml = project / "project.toml"
    text = toml.read_text()
    assert not check_project(load_file(toml)).errors
    toml.write_text(text.replace('dealt = "green"', 'dealt = "gren"'))
    errors = check_project(load_file(toml)).errors
    found = [f for f in errors if "[map]" in f.message]
    assert found and "not a style" in found[0].message, errors
    assert found[0].line == text.splitlines().index('dealt = "green"') + 1
    toml.write_text(text.replace('polygon = "fill"', 'polygone = "fill"'))
    found = [f for f in check_project(load_file(toml)).errors if "[map]" in f.message]
    assert found and "did you mean 'polygon'" in found[0].message
    toml.write_text(text.replace("[map.kinds.area]", "[map.kinds.areas]"))
    warnings = [f for f in check_project(load_file(toml)).warnings if "[map]" in f.message]
    assert warnings and "'areas'" in warnings[0].message


def test_the_running_map_shows_a_plan_and_a_styled_object(
        endpoints: BusEndpoints, peer: Peer, world: WorldService) -> None:  # noqa: F811
    world.world.upsert(WorldObject.from_json(
        {"id": "h1", "kind": "hotspot", "position": {"lat": 47.068, "lon": 15.435},
         "attributes": {"state": "dealt"}}))
    styles = read_map(load_file(TUIMAP).sections["map"], file=str(TUIMAP))

    async def body() -> None:
        app = MrssApp(endpoints, project="demo", mind_every=0.0, tree_every=0.0,
                      world_every=0.2, map_config=styles)
        async with app.run_test(size=(180, 50)) as pilot:
            await connected(pilot, peer)
            panel = app.query_one(MapPanel)
            peer.publish(data("uav1", type="position", lat=47.065, lon=15.430),
                         src="telemetry")
            peer.publish(data("uav1", **plan_record("a1", LANES, 3)), src="rcl")
            await until(pilot, lambda: "uav1" in app.map_model.plans and
                        "h1" in app.map_model.objects, message="the plan and h1")
            width, height = panel.content_size.width, panel.content_size.height

            def drawn() -> tuple[str, str, set[str]]:
                # the view the panel fitted when it last drew (at most a second after a
                # change: the map is redrawn at most once a table_every)
                canvas = app.map_model.draw(panel.view, width, height)
                grid = cell_styles(canvas)
                col, row = panel.view.to_cell(47.068, 15.435, width, height)
                return canvas.text()[row][col], grid[row][col], {s for ln in grid for s in ln}

            await until(pilot, lambda: {"dim cyan", "bold cyan"} <= drawn()[2],
                        message="the lanes flown and left drawn")
            glyph, style, _ = drawn()
            assert (glyph, style) == ("✹", "green")
            # the robot's detail shows the plan's size, not every waypoint
            assert ("plan.waypoints", "[6 items]") in app.robots.robots["uav1"].fields()
            panel.focus()
            await pilot.press("f")  # follow uav1: the title says how far along its plan
            await until(pilot, lambda: "plan 3/6" in str(panel.border_title),
                        message="the plan in the title")
            peer.publish(data("uav1", **clear_record("a1")), src="rcl")
            await until(pilot, lambda: "uav1" not in app.map_model.plans,
                        message="the plan cleared")
    run(body())


def test_a_line_is_walked_only_where_it_crosses_the_canvas() -> None:
    canvas = BrailleCanvas(W, H)
    canvas.line(-1e9, 5.0, 1e9, 5.0, "x")  # a lane far longer than the view, zoomed in
    canvas.line(-1e9, -50.0, 1e9, -40.0, "y")  # above the canvas: nothing
    canvas.line(float("nan"), 1.0, 3.0, 1.0, "z")
    rows = canvas.text()
    assert all(ch != " " for ch in rows[1]) and len(rows[1]) == W
    assert all(ch == " " for i, row in enumerate(rows) if i != 1 for ch in row)
    assert {style for run in canvas.rows()[1] for _, style in [run]} == {"x"}
