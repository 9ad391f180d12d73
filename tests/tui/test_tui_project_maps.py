"""The projects' dashboard maps: wildfire's hotspots take the state the UGV's SupplyWater
says (`supply` records, datalayer.py), which its [map] colours, and its cover plan fits
the data layer's limits; AMADEE's zones are outlines of their own styles, its
communication zone a ring of the habitat's `comm_radius_m`. In-process, nothing started
(projects/ may import only mrss.api, so these live here)."""

from __future__ import annotations

import json
from pathlib import Path

from mrss.actors.datalayer.layer import DataLayerContext
from mrss.api.testing import memory_world
from mrss.config.loader import load_file
from mrss.config.map import read_map
from mrss.edge.record_declarations import DEFAULT_LIMITS, RobotType
from mrss.edge.validation import check_record
from mrss.messages.plans import PLAN_MAX_WAYPOINTS, plan_record
from mrss.runtime.loader import import_project_module
from mrss.tui.models.geo import METRES_PER_DEGREE, Viewport
from mrss.tui.models.map import MapModel

PROJECTS = Path(__file__).resolve().parents[2] / "projects"
WILDFIRE = PROJECTS / "wildfire"
AMADEE = PROJECTS / "amadee"


def test_supply_records_set_the_hotspot_state_that_the_map_colours() -> None:
    datalayer = import_project_module(WILDFIRE, "datalayer.py")
    world = memory_world()
    data = datalayer.WildfireData(DataLayerContext(world=world))
    data.start()
    data.on_telemetry("uav1", {"type": "hotspot", "id": 1, "lat": -35.36, "lon": 149.16,
                               "temperature": 480.0})
    styles = read_map(load_file(WILDFIRE / "project.toml").sections["map"])

    def look() -> tuple[str, str]:
        found = world.get("hs1")
        assert found is not None
        return styles.point_look("hotspot", found.get("attributes", {}))

    assert look() == ("✹", "bold red")  # new: no state yet
    for state, style in (("supplying", "bold yellow"), ("supplied", "green")):
        data.on_telemetry("ugv1", {"type": "supply", "target": "hs1", "state": state})
        assert look() == ("✹", style)
    # a hotspot seen again keeps its state; bad supply records change nothing
    data.on_telemetry("uav1", {"type": "hotspot", "id": 1, "lat": -35.36, "lon": 149.16,
                               "temperature": 470.0})
    for bad in ({"target": "hs1", "state": "burning"}, {"target": 1, "state": "new"},
                {"target": "hs7", "state": "new"}, {"target": "uav_home", "state": "new"}):
        data.on_telemetry("ugv1", {"type": "supply", **bad})
    assert look() == ("✹", "green")
    assert world.get("hs7") is None
    assert styles.hide == {"robot"}


def test_a_cover_plan_record_passes_the_data_layers_checks() -> None:
    sweep = import_project_module(WILDFIRE, "sweep.py")
    square = [[-35.360, 149.160], [-35.360, 149.170], [-35.370, 149.170],
              [-35.370, 149.160]]
    waypoints = sweep.lawnmower(square, 5.0)  # 446 waypoints: more than one record holds
    assert len(waypoints) > PLAN_MAX_WAYPOINTS
    record = plan_record("a1", waypoints, 3, "north")
    assert check_record(record, DEFAULT_LIMITS[RobotType.AERIAL]) == record
    assert record["waypoints"][-1] == list(map(float, waypoints[-1]))  # type: ignore[index]


def test_the_amadee_zones_have_their_own_outline_styles() -> None:
    toml = AMADEE / "project.toml"
    styles = read_map(load_file(toml).sections["map"], file=str(toml))
    zones = {kind: styles.line_style(kind, {}) for kind in ("no_go", "protected", "terrain")}
    assert len(set(zones.values())) == 3 and zones["no_go"] == "bold red"
    assert styles.point_look("crew", {}) == ("☺", "bold yellow")
    # the communication zone: a ring of the habitat's comm_radius_m, drawn on the map
    seed = json.loads((AMADEE / "world.json").read_text())
    model = MapModel(styles)
    model.apply_world(seed)
    assert styles.ring("base", model.objects["habitat"].attributes) == (400.0, "dim cyan")
    view = Viewport(lat=39.7700, lon=44.8000, scale=10.0)  # 10 m a dot: the ring 40 dots
    canvas = model.draw(view, 60, 24)
    north = view.to_cell(39.7700 + 400 / METRES_PER_DEGREE, 44.8000, 60, 24)
    assert canvas.text()[north[1]][north[0]] != " "
    assert styles.line_style("no_go", {}) == "bold red"
