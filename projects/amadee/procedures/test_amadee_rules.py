"""Unit tests of each operational rule of legality.py, on a real embedded world model
seeded with the project's world.json (the same spatial predicates as `mrss supervise`).

The habitat is at 39.7700, 44.8000; the salt marsh (no-go) 110-220 m north-east of it,
the biosignature site (protected) 90-170 m south-west, crew member eva1 170 m west,
the crater rim (a terrain grid) 170-340 m east: gentle in its western half, then a
wall of about 19 degrees.
"""

from __future__ import annotations

import json
from pathlib import Path
from typing import Any

import pytest

from mrss.api import import_project_module
from mrss.api.testing import LocalWorldModel, memory_world

PROJECT = Path(__file__).resolve().parent.parent
legality = import_project_module(PROJECT, "legality.py")
HOME = (39.7700, 44.8000)


@pytest.fixture
def world() -> LocalWorldModel:
    return memory_world(json.loads((PROJECT / "world.json").read_text(encoding="utf-8")))


def place(world: LocalWorldModel, lat: float = HOME[0], lon: float = HOME[1],
          speed: float = 0.0, battery: float = 100.0) -> None:
    world.upsert({"id": "rover1", "kind": "robot", "position": {"lat": lat, "lon": lon},
                  "attributes": {"speed": speed, "battery": battery}})


def judge(world: LocalWorldModel, action: str, now: float | None = None) -> Any:
    return legality.verdict(legality.request_of(action, world, now), world)


NOW = 1_795_000_000.0   # 2026-11-18T11:06:40Z


def blackout(start: str = "2026-11-18T11:00:00Z", end: str = "2026-11-18T11:20:00+00:00",
             **attributes: Any) -> dict[str, Any]:
    return {"id": "relay_pass", "kind": "time_window",
            "attributes": {"what": "comms blackout", "start": start, "end": end,
                           **attributes}}


def test_a_short_drive_in_the_open_is_legal(world: LocalWorldModel) -> None:
    place(world)
    found = judge(world, "drive(rover1,g1,39.7705,44.8)")
    assert found.legal and found.as_answer() == ["legal"]


def test_a_path_through_the_no_go_zone_is_illegal_though_its_end_is_outside(
        world: LocalWorldModel) -> None:
    place(world)
    found = judge(world, "drive(rover1,g1,39.7725,44.801)")   # beyond the marsh
    assert not found.legal and found.rule == "no_go_path"
    assert "'salt_marsh'" in found.detail and found.geometry["type"] == "Polygon"
    assert found.as_answer()[:2] == ["illegal", "no_go_path"]
    place(world, 39.7725, 44.8000)                             # from the north, around it
    assert judge(world, "drive(rover1,g2,39.7725,44.801)").legal


def test_a_path_through_the_protected_zone_is_illegal(world: LocalWorldModel) -> None:
    place(world)
    found = judge(world, "drive(rover1,g1,39.768,44.7985)")
    assert not found.legal and found.rule == "protected_path"
    assert "'biosig_site'" in found.detail


def test_leaving_the_communication_zone_is_illegal(world: LocalWorldModel) -> None:
    place(world)
    found = judge(world, "drive(rover1,g1,39.7740,44.7960)")   # ~560 m north-west
    assert not found.legal and found.rule == "communication_zone"
    assert "outside the communication zone of 400 m" in found.detail
    assert judge(world, "drive(rover1,g1,39.7730,44.7990)").legal   # ~340 m


def test_driving_near_crew_on_eva_is_illegal(world: LocalWorldModel) -> None:
    place(world)
    found = judge(world, "drive(rover1,g1,39.7700,44.7982)")   # 17 m short of eva1
    assert not found.legal and found.rule == "crew_safety"
    assert "'eva1'" in found.detail and "closer than 25 m" in found.detail
    assert judge(world, "drive(rover1,g1,39.7700,44.7990)").legal   # 85 m short
    world.upsert({"id": "eva1", "kind": "crew", "position": {"lat": 39.7701, "lon": 44.8}})
    assert judge(world, "image(rover1,g2)").rule == "crew_safety"   # she walked over


def test_a_drive_without_battery_to_come_back_is_illegal(world: LocalWorldModel) -> None:
    place(world, battery=20.0)     # 187 m there and 187 back at 0.02 %/m + 15 % = 22.5 %
    found = judge(world, "drive(rover1,g1,39.7715,44.7990)")
    assert not found.legal and found.rule == "battery_reserve"
    assert "the battery has 20.0%" in found.detail
    place(world, battery=23.0)
    assert judge(world, "drive(rover1,g1,39.7715,44.7990)").legal


def test_the_arm_deploys_only_when_the_rover_is_stopped(world: LocalWorldModel) -> None:
    place(world, 39.7705, 44.8, speed=0.8)
    for action in ("spectrum(rover1,g1)", "sample(rover1,g1)"):
        found = judge(world, action)
        assert not found.legal and found.rule == "arm_when_stopped", action
    assert judge(world, "image(rover1,g1)").legal    # the camera needs no arm
    place(world, 39.7705, 44.8, speed=0.0)
    assert judge(world, "sample(rover1,g1)").legal
    place(world, 39.7705, 44.8, speed=0.04)                 # creeping: under 0.05 m/s
    assert judge(world, "sample(rover1,g1)").legal
    world.upsert({"id": "habitat", "kind": "base", "attributes": {"stopped_mps": 0.01}})
    found = judge(world, "sample(rover1,g1)")
    assert found.rule == "arm_when_stopped" and "(at most 0.01 m/s)" in found.detail


def test_no_sampling_in_a_protected_zone(world: LocalWorldModel) -> None:
    place(world, 39.7688, 44.7995)                   # inside the biosignature site
    found = judge(world, "sample(rover1,g1)")
    assert not found.legal and found.rule == "no_sampling_protected"
    assert "'biosig_site'" in found.detail
    assert judge(world, "image(rover1,g1)").legal    # looking is allowed


def test_a_path_up_the_crater_wall_is_too_steep(world: LocalWorldModel) -> None:
    place(world)
    found = judge(world, "drive(rover1,g1,39.77,44.8036)")    # across the wall
    assert not found.legal and found.rule == "slope_limit"
    assert "on terrain 'crater_rim', steeper than 15°" in found.detail
    slope = float(found.detail.split(" climbs ")[1].split("°")[0])
    assert 17.0 < slope < 21.0, found.detail
    assert found.geometry["type"] == "LineString"             # the steep stretch
    assert all(44.8025 <= lon <= 44.8035 for lon, _ in found.geometry["coordinates"])
    assert judge(world, "drive(rover1,g1,39.77,44.8028)").legal   # its gentle foot
    world.upsert({"id": "habitat", "kind": "base", "attributes": {"max_slope_deg": 25}})
    assert judge(world, "drive(rover1,g1,39.77,44.8036)").legal   # the operator's limit


def test_a_malformed_terrain_grid_is_named_and_nothing_moves(world: LocalWorldModel) -> None:
    place(world)
    world.upsert({"id": "crater_rim", "kind": "terrain",
                  "attributes": {"elevation_m": [[0, 1], [0, "high"]]}})
    found = legality.judge("drive(rover1,g1,39.77,44.8028)", world)
    assert (found.legal, found.rule) == (False, "unchecked")
    assert "terrain 'crater_rim': elevation_m[1][1] must be a finite number" in found.detail


def test_no_driving_during_a_comms_blackout(world: LocalWorldModel) -> None:
    place(world)
    world.upsert(blackout())
    found = judge(world, "drive(rover1,g1,39.7705,44.8)", NOW)
    assert not found.legal and found.rule == "time_window"
    assert ("drive is forbidden by time window 'relay_pass' (comms blackout) from "
            "2026-11-18T11:00:00Z to 2026-11-18T11:20:00Z") in found.detail
    assert found.geometry["type"] == "LineString"
    assert judge(world, "return_home(rover1,g2)", NOW).rule == "time_window"
    assert judge(world, "image(rover1,g3)", NOW).legal                # not forbidden
    assert judge(world, "drive(rover1,g1,39.7705,44.8)", NOW + 800).legal   # ended
    world.upsert(blackout(forbids=["image"]))
    assert judge(world, "image(rover1,g3)", NOW).rule == "time_window"
    assert judge(world, "drive(rover1,g1,39.7705,44.8)", NOW).legal


@pytest.mark.parametrize("attributes, message", [
    ({"start": "2026-11-18T11:00:00"}, "start must be an ISO 8601 time with a zone"),
    ({"end": "tomorrow"}, "end must be an ISO 8601 time"),
    ({"forbids": "drive"}, "forbids must be a list of action names"),
])
def test_a_malformed_time_window_is_named(world: LocalWorldModel,
                                          attributes: dict[str, Any], message: str) -> None:
    place(world)
    world.upsert(blackout(**attributes))
    found = legality.judge("drive(rover1,g1,39.7705,44.8)", world, NOW)
    assert (found.legal, found.rule) == (False, "unchecked")
    assert f"time window 'relay_pass': {message}" in found.detail


def test_return_home_is_checked_as_a_drive(world: LocalWorldModel) -> None:
    place(world, 39.7725, 44.801)                    # home lies beyond the marsh
    assert judge(world, "return_home(rover1,g1)").rule == "no_go_path"


def test_a_drive_to_where_the_rover_stands_is_checked_in_place(
        world: LocalWorldModel) -> None:
    place(world, 39.7705, 44.8)
    assert judge(world, "drive(rover1,g1,39.7705,44.8)").legal     # no path to cross
    place(world)
    assert judge(world, "return_home(rover1,g2)").legal             # at home already
    world.upsert({"id": "eva1", "kind": "crew", "position": {"lat": 39.7701, "lon": 44.8}})
    found = judge(world, "return_home(rover1,g2)")
    assert found.rule == "crew_safety" and "from the rover," in found.detail


@pytest.mark.parametrize("action, message", [
    ("fly(rover1,g1)", "no rules for action 'fly'"),
    ("drive(rover1,g1,north)", "expected drive(Robot, Goal, Lat, Lon)"),
    ("drive(nobody,g1,39.77,44.8)", "no position of robot 'nobody'"),
    ("Drive(", "not an action"),
])
def test_a_bad_action_is_named(world: LocalWorldModel, action: str, message: str) -> None:
    place(world)
    with pytest.raises((ValueError, LookupError), match=message.replace("(", r"\(")
                       .replace(")", r"\)")):
        legality.request_of(action, world)


def test_the_world_answers_the_spatial_question_the_docs_show(world: LocalWorldModel) -> None:
    place(world, 39.77, 44.8)   # docs/projects.md, "Testing functions over the world model"
    path = {"type": "LineString", "coordinates": [[44.8, 39.77], [44.801, 39.7725]]}
    assert world.intersecting(path, "no_go")[0]["id"] == "salt_marsh"
    assert world.intersecting(path, "protected") == []


def test_an_action_that_cannot_be_checked_is_refused_with_the_reason(
        world: LocalWorldModel) -> None:
    found = legality.judge("drive(rover1,g1,39.7705,44.8)", world)   # no telemetry yet
    assert (found.legal, found.rule) == (False, "unchecked")
    assert "no position of robot 'rover1'" in found.detail
    place(world)
    assert legality.judge("drive(rover1,g1,39.7705,44.8)", world).legal
    assert legality.judge("fly(rover1,g1)", world).rule == "unchecked"
    assert legality.goal_of("drive(rover1,g1,39.7705,44.8)") == "g1"
    assert legality.goal_of("Drive(") is None and legality.goal_of("image(rover1)") is None


# -- a rover inside the no-go zone: only the shortest legal way out ----------------------------
INSIDE = (39.7712, 44.8010)   # in the salt marsh, 22 m from its south edge (43+ m from others)


def test_a_rover_inside_the_no_go_zone_may_only_leave_by_the_shortest_way(
        world: LocalWorldModel) -> None:
    place(world, *INSIDE)
    zones = world.objects("no_go")
    way_out = legality.shortest_exit(*INSIDE, zones)
    assert way_out is not None and way_out.zone == "salt_marsh"
    assert abs(way_out.lon - INSIDE[1]) < 1e-7 and way_out.lat < 39.7710  # south, outside
    assert 22.0 < way_out.distance_m < 24.5   # the edge 22.2 m away, plus the 1 m margin
    home = judge(world, "return_home(rover1,g1)")
    assert not home.legal and home.rule == "no_go_path"
    assert f"{way_out.lat:.6f},{way_out.lon:.6f}" in home.detail
    out = judge(world, f"drive(rover1,g2,{way_out.lat:.7f},{way_out.lon:.7f})")
    assert out.legal, out
    far_edge = judge(world, "drive(rover1,g3,39.7721,44.8010)")   # out by the north edge
    assert not far_edge.legal and far_edge.rule == "no_go_path"
