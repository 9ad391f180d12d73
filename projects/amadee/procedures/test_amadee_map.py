"""The AMADEE dashboard map's styles (project.toml [map]): the zones of world.json as
outlines of their own styles, the crew, and the communication zone as a ring of the
habitat's `comm_radius_m`. In-process, no system started."""

from __future__ import annotations

import json
from pathlib import Path

from mrss.config import load_file
from mrss.map_config import read_map
from mrss.tui.models.geo import METRES_PER_DEGREE, Viewport
from mrss.tui.models.map import MapModel

PROJECT = Path(__file__).resolve().parent.parent


def test_the_amadee_zones_have_their_own_outline_styles() -> None:
    toml = PROJECT / "project.toml"
    styles = read_map(load_file(toml).sections["map"], file=str(toml))
    zones = {kind: styles.line_style(kind, {}) for kind in ("no_go", "protected", "terrain")}
    assert len(set(zones.values())) == 3 and zones["no_go"] == "bold red"
    assert styles.point_look("crew", {}) == ("☺", "bold yellow")
    # the communication zone: a ring of the habitat's comm_radius_m, drawn on the map
    seed = json.loads((PROJECT / "world.json").read_text())
    model = MapModel(styles)
    model.apply_world(seed)
    assert styles.ring("base", model.objects["habitat"].attributes) == (400.0, "dim cyan")
    view = Viewport(lat=39.7700, lon=44.8000, scale=10.0)  # 10 m a dot: the ring 40 dots
    canvas = model.draw(view, 60, 24)
    north = view.to_cell(39.7700 + 400 / METRES_PER_DEGREE, 44.8000, 60, 24)
    assert canvas.text()[north[1]][north[0]] != " "
    assert styles.line_style("no_go", {}) == "bold red"
