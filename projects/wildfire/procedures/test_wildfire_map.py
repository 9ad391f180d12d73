"""The wildfire dashboard map's data: hotspots take the state the UGV's SupplyWater says
(`supply` records, datalayer.py), which project.toml's [map] colours; the cover skill's
plan record fits the data layer's limits. In-process, no system started."""

from __future__ import annotations

from pathlib import Path

from mrss.api.testing import memory_world
from mrss.config import load_file
from mrss.edge.adapters import DataLayerContext
from mrss.edge.loader import import_project_module
from mrss.edge.validation import DEFAULT_LIMITS, RobotType, check_record
from mrss.map_config import read_map
from mrss.plans import PLAN_MAX_WAYPOINTS, plan_record

PROJECT = Path(__file__).resolve().parent.parent


def test_supply_records_set_the_hotspot_state_that_the_map_colours() -> None:
    datalayer = import_project_module(PROJECT, "datalayer.py")
    world = memory_world()
    data = datalayer.WildfireData(DataLayerContext(world=world))
    data.start()
    data.on_telemetry("uav1", {"type": "hotspot", "id": 1, "lat": -35.36, "lon": 149.16,
                               "temperature": 480.0})
    styles = read_map(load_file(PROJECT / "project.toml").sections["map"])

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
    sweep = import_project_module(PROJECT, "sweep.py")
    square = [[-35.360, 149.160], [-35.360, 149.170], [-35.370, 149.170],
              [-35.370, 149.160]]
    waypoints = sweep.lawnmower(square, 5.0)  # 446 waypoints: more than one record holds
    assert len(waypoints) > PLAN_MAX_WAYPOINTS
    record = plan_record("a1", waypoints, 3, "north")
    assert check_record(record, DEFAULT_LIMITS[RobotType.AERIAL]) == record
    assert record["waypoints"][-1] == list(map(float, waypoints[-1]))  # type: ignore[index]
