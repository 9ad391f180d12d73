"""Hotspot lists from the command line and files, and the thermal camera's detections."""

from __future__ import annotations

from pathlib import Path

import pytest

from mrss.errors import ConfigError
from mrss.links.geo import offset
from mrss.sim.hotspots import Hotspot, ThermalCamera, hotspots_from_records, parse_hotspots


def test_inline_list_with_optional_temperature() -> None:
    spots = parse_hotspots("-35.1,149.2; -35.2,149.3,650")
    assert spots == [Hotspot(1, -35.1, 149.2, 400.0), Hotspot(2, -35.2, 149.3, 650.0)]
    assert parse_hotspots("") == []


def test_text_and_json_files(tmp_path: Path) -> None:
    text = tmp_path / "spots.txt"
    text.write_text("# fire front\n-35.1, 149.2\n\n-35.2,149.3,500  # big one\n")
    assert [h.temperature for h in parse_hotspots(str(text))] == [400.0, 500.0]
    js = tmp_path / "spots.json"
    js.write_text('[{"id": 7, "lat": -35.1, "lon": 149.2, "temperature": 300}]')
    assert parse_hotspots(str(js)) == [Hotspot(7, -35.1, 149.2, 300.0)]


@pytest.mark.parametrize("spec, message", [
    ("-35.1", "expected LAT,LON"),
    ("-35.1,abc", "could not convert"),
    ("95,10", "out of range"),
])
def test_bad_inline_lists_name_the_problem(spec: str, message: str) -> None:
    with pytest.raises(ConfigError, match=message):
        parse_hotspots(spec)


def test_bad_json_file_names_the_file(tmp_path: Path) -> None:
    js = tmp_path / "spots.json"
    js.write_text('{"lat": 1}')
    with pytest.raises(ConfigError, match="spots.json"):
        parse_hotspots(str(js))
    with pytest.raises(ConfigError, match="bad record"):
        hotspots_from_records([{"lat": "x", "lon": 1}], "project.toml")


def test_camera_reports_each_entry_into_view_once() -> None:
    spot = Hotspot(1, -35.0, 149.0)
    camera = ThermalCamera([spot], radius_m=20.0, min_alt_m=2.0)
    near = offset(spot.lat, spot.lon, 15.0, 0.0)
    far = offset(spot.lat, spot.lon, 30.0, 0.0)
    assert camera.scan(*near, 1.0) == []  # too low to see
    assert camera.scan(*near, 10.0) == [spot]
    assert camera.scan(spot.lat, spot.lon, 10.0) == []  # still in view: not again
    assert camera.scan(*far, 10.0) == []
    assert camera.scan(*near, 10.0) == [spot]  # came back into view
    assert camera.seen == {1}
