"""The map's pure parts: lat/lon to braille dots and back, the canvas, what the map draws."""

from __future__ import annotations

import pytest

from mrss.messages import RobotData
from mrss.tui.models.braille import BrailleCanvas
from mrss.tui.models.geo import METRES_PER_DEGREE, Viewport, heading_arrow
from mrss.tui.models.map import MapModel, telemetry_position

W, H = 40, 12  # cells: 80 x 48 dots


def test_the_centre_is_the_middle_of_the_canvas_and_north_is_up() -> None:
    view = Viewport(lat=43.6, lon=1.44, scale=10.0)
    assert view.to_dots(43.6, 1.44, W, H) == (40.0, 24.0)
    assert view.to_cell(43.6, 1.44, W, H) == (20, 6)
    x, y = view.to_dots(43.6 + 100 / METRES_PER_DEGREE, 1.44, W, H)  # 100 m north
    assert (x, y) == pytest.approx((40.0, 14.0))  # 10 dots up
    x, _ = view.to_dots(43.6, 1.44 + 0.001, W, H)  # east: shrunk by cos(lat)
    assert x == pytest.approx(40.0 + 0.001 * METRES_PER_DEGREE * 0.72417 / 10, rel=1e-4)


def test_to_latlon_inverts_to_dots() -> None:
    view = Viewport(lat=-35.36, lon=149.16, scale=3.0)
    lat, lon = view.to_latlon(*view.to_dots(-35.3612, 149.1655, W, H), W, H)
    assert (lat, lon) == pytest.approx((-35.3612, 149.1655), abs=1e-9)


def test_zoom_and_pan_move_the_view_and_zoom_is_bounded() -> None:
    view = Viewport(lat=0.0, lon=0.0, scale=10.0)
    view.zoom(2.0)
    assert view.scale == 5.0
    for _ in range(100):
        view.zoom(10.0)
    assert view.scale == 0.05  # not beyond the closest zoom
    view = Viewport(lat=0.0, lon=0.0, scale=10.0)
    view.pan(0.25, 0.0, W, H)  # a quarter of 80 dots at 10 m: 200 m east
    assert view.lon * METRES_PER_DEGREE == pytest.approx(200.0)
    assert view.lat == 0.0
    view.pan(0.0, -0.5, W, H)  # half of 48 dots up: 240 m north
    assert view.lat * METRES_PER_DEGREE == pytest.approx(240.0)


def test_fit_shows_every_point_inside_the_canvas() -> None:
    view = Viewport()
    points = [(43.60, 1.44), (43.61, 1.46), (43.605, 1.43)]
    assert view.fit(points, W, H)
    for lat, lon in points:
        col, row = view.to_cell(lat, lon, W, H)
        assert 0 <= col < W and 0 <= row < H
    assert not Viewport().fit([], W, H)
    one = Viewport()
    one.fit([(10.0, 20.0)], W, H)  # one point: centred, a sane scale
    assert (one.lat, one.lon, one.scale) == (10.0, 20.0, 1.0)


def test_heading_arrows() -> None:
    assert [heading_arrow(h) for h in (0, 44, 90, 180, 270, 359, -90)] == \
        ["↑", "↗", "→", "↓", "←", "↑", "←"]
    assert heading_arrow(None) == heading_arrow(float("nan")) == "●"


def test_braille_canvas_dots_lines_glyphs_and_labels() -> None:
    canvas = BrailleCanvas(3, 2)
    canvas.dot(0, 0)
    canvas.dot(1, 3)
    canvas.dot(99, 99)  # off the canvas: dropped
    canvas.dot(float("inf"), 0)
    assert canvas.text()[0][0] == chr(0x2800 + 0x01 + 0x80)
    canvas.line(0, 4, 5, 4, "red")
    assert canvas.text()[1] == "⠉⠉⠉"
    assert canvas.rows()[1] == [("⠉⠉⠉", "red")]
    assert canvas.glyph(1, 0, "R", "bold")
    assert not canvas.glyph(3, 0, "R")
    canvas.label(2, 1, "toolong")  # cropped at the edge
    assert canvas.text() == [canvas.text()[0][0] + "R ", "⠉⠉t"]
    canvas.label(0, 0, "xy")  # stops before an existing glyph
    assert canvas.text()[0] == "xR "


def test_telemetry_positions_in_both_shapes_and_bad_ones_refused() -> None:
    assert telemetry_position({"type": "position", "lat": 1.0, "lon": 2.0,
                               "heading": 90}) == (1.0, 2.0, 90.0)
    assert telemetry_position({"lat": 1, "lon": 2}) == (1.0, 2.0, None)
    assert telemetry_position({"type": "battery", "lat": 1.0, "lon": 2.0}) is None
    for bad in ({"lat": "1", "lon": 2}, {"lat": 91.0, "lon": 0.0}, {"lat": True, "lon": 1},
                {"lat": float("nan"), "lon": 1.0}, {}):
        assert telemetry_position(bad) is None


def data(robot: str, lat: float, lon: float, heading: float | None = None) -> RobotData:
    record: dict[str, object] = {"type": "position", "lat": lat, "lon": lon}
    if heading is not None:
        record["heading"] = heading
    return RobotData(robot=robot, data=record)  # type: ignore[arg-type]


def test_the_map_draws_robots_with_heading_tracks_objects_and_areas() -> None:
    model = MapModel()
    assert model.apply_data(data("ugv1", 43.600, 1.440, 45))
    assert model.apply_data(data("ugv1", 43.601, 1.441))  # no heading: the last one stays
    assert not model.apply_data(RobotData(robot="ugv1", data={"type": "battery",
                                                              "remaining": 50}))
    assert list(model.robots["ugv1"].track) == [(43.600, 1.440), (43.601, 1.441)]
    area = {"type": "Polygon", "coordinates": [[[1.438, 43.598], [1.444, 43.598],
                                                [1.444, 43.604], [1.438, 43.604],
                                                [1.438, 43.598]]]}
    assert model.apply_world([
        {"id": "h1", "kind": "hotspot", "position": {"lat": 43.603, "lon": 1.443}},
        {"id": "w1", "kind": "water_source", "position": {"lat": 43.599, "lon": 1.439}},
        {"id": "area1", "kind": "area", "position": None, "geometry": area},
        {"id": "nowhere", "kind": "note"}, "junk", {"kind": "no id"}])
    assert set(model.objects) == {"h1", "w1", "area1"}
    assert not model.apply_world({"not": "a list"})
    view = Viewport()
    view.fit(model.points(), W, H)
    text = "\n".join(model.draw(view, W, H).text())
    assert "↗ugv1" in text and "✹h1" in text and "≈w1" in text and "area1" in text
    assert any(ch in text for ch in "⡇⢸")  # the area's sides, in braille
    col, row = view.to_cell(43.601, 1.441, W, H)
    assert model.draw(view, W, H).text()[row][col] == "↗"


def test_a_robot_on_an_object_keeps_its_glyph_and_whole_name_on_top() -> None:
    model = MapModel()
    model.apply_data(data("ugv1", 43.600, 1.440, 0))
    model.apply_world([  # the base the robot stands on, and another base further away
        {"id": "ugv_base", "kind": "base", "position": {"lat": 43.600, "lon": 1.440}},
        {"id": "far", "kind": "base", "position": {"lat": 43.610, "lon": 1.450}}])
    view = Viewport()
    view.fit(model.points(), W, H)
    rows = model.draw(view, W, H).text()
    col, row = view.to_cell(43.600, 1.440, W, H)
    assert rows[row][col:col + 5] == "↑ugv1"  # not the base's name over the robot's
    assert "ugv_base" not in "\n".join(rows)  # hidden under the robot, not mixed in
    assert "far" in "\n".join(rows)
