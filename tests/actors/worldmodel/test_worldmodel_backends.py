"""One test suite for every world model backend: embedded SQLite and PostgreSQL + PostGIS.

Each test runs once per backend (`open_store`, tests/edge/conftest.py). The PostGIS runs
start a private PostgreSQL 15 server with the postgis extension on a free loopback port;
they are skipped when PostgreSQL 15 or postgresql-15-postgis-3 is not installed, and
fail instead when MRSS_REQUIRE_POSTGIS=1 (as in CI).
"""

from __future__ import annotations

import json
import math
import threading
from typing import Any, cast

import pytest

from mrss.actors.worldmodel.model import WorldModel
from mrss.actors.worldmodel.rules import NoObjectWithin, RuleEngine
from mrss.actors.worldmodel.store import (
    Geometry,
    Position,
    SqliteWorldStore,
    WorldObject,
    WorldStore,
)
from mrss.errors import ConfigError
from mrss.messages import DataRequest
from tests.actors.worldmodel.stores import StoreFactory

BASE = Position(43.6045, 1.4440)
M_PER_DEG = 6_371_008.8 * math.pi / 180  # metres per degree of latitude on the sphere


def north(metres: float, east: float = 0.0) -> tuple[float, float]:
    """(lon, lat) `metres` north and `east` metres east of BASE."""
    return (BASE.lon + east / (M_PER_DEG * math.cos(math.radians(BASE.lat))),
            BASE.lat + metres / M_PER_DEG)


def at(metres: float, east: float = 0.0) -> Position:
    lon, lat = north(metres, east)
    return Position(lat, lon)


def square(south: float, west: float, size: float) -> dict[str, Any]:
    """A GeoJSON square polygon, corners in metres from BASE."""
    ring = [north(south, west), north(south, west + size), north(south + size, west + size),
            north(south + size, west), north(south, west)]
    return {"type": "Polygon", "coordinates": [[list(c) for c in ring]]}


def line(*points: tuple[float, float]) -> dict[str, Any]:
    """A GeoJSON line through (north, east) metre offsets."""
    return {"type": "LineString", "coordinates": [list(north(n, e)) for n, e in points]}


def obj(oid: str, kind: str, **fields: Any) -> WorldObject:
    return WorldObject.from_json({"id": oid, "kind": kind, **fields})


def ids(found: list[Any]) -> list[str]:
    return [(o[0] if isinstance(o, tuple) else o).id for o in found]


def test_upsert_merges_reports_changes_and_survives_reopening(open_store: StoreFactory) -> None:
    store = open_store()
    first = store.upsert(WorldObject("uav1", "robot", BASE, {"battery": 90}))
    assert first.op == "insert" and first.obj.version == 1 and first.previous is None
    assert store.upsert(WorldObject("uav1", "robot", None, {"battery": 90})).op == "unchanged"
    moved = store.upsert(WorldObject("uav1", "robot", at(10), {"mode": "guided"}))
    assert moved.op == "update" and moved.obj.version == 2
    assert moved.obj.attributes == {"battery": 90, "mode": "guided"}
    assert moved.previous is not None and moved.previous.position == BASE
    replaced = store.upsert(WorldObject("uav1", "robot", None, {"x": [1, {"y": None}]}),
                            replace_attributes=True)
    assert replaced.obj.attributes == {"x": [1, {"y": None}]}
    store.close()
    reopened = open_store()
    got = reopened.get("uav1")
    assert got is not None and got.position == at(10) and got.version == 3
    assert got.attributes == {"x": [1, {"y": None}]}
    assert [o.id for o in reopened.objects("robot")] == ["uav1"]
    assert reopened.objects("hotspot") == [] and reopened.get("nope") is None
    assert ids(reopened.near(at(10), 5)) == ["uav1"]
    assert reopened.delete("uav1") and not reopened.delete("uav1")
    assert reopened.near(at(10), 5) == [] and reopened.objects() == []


def test_lines_and_polygons_round_trip_and_a_shape_can_change(open_store: StoreFactory) -> None:
    store = open_store()
    area = obj("zone1", "zone", geometry=square(0, 0, 100), attributes={"name": "A"})
    road = obj("road1", "road", geometry=line((0, 0), (50, 10), (100, 0)))
    store.upsert(area)
    store.upsert(road)
    store.upsert(obj("b1", "base", geometry={"type": "Point",
                                             "coordinates": [BASE.lon, BASE.lat, 150]}))
    store.close()
    store = open_store()
    got = store.get("zone1")
    assert got is not None and got.geometry == area.geometry and got.position is None
    assert got.to_json()["geometry"] == square(0, 0, 100)
    got_road = store.get("road1")
    assert got_road is not None and got_road.geometry == road.geometry
    point = store.get("b1")
    assert point is not None and point.position == Position(BASE.lat, BASE.lon, 150)
    assert point.geometry is None
    # Attributes alone keep the shape; a new shape replaces the old one.
    kept = store.upsert(obj("zone1", "zone", attributes={"x": 1}))
    assert kept.op == "update" and kept.obj.geometry == area.geometry
    as_point = store.upsert(obj("zone1", "zone", position={"lat": BASE.lat, "lon": BASE.lon}))
    assert as_point.op == "update" and as_point.obj.geometry is None
    assert ids(store.near(BASE, 1)) == ["b1", "road1", "zone1"]


def test_near_orders_by_distance_and_filters_by_kind(open_store: StoreFactory) -> None:
    store = open_store()
    store.upsert(WorldObject("w_far", "water_source", at(900)))
    store.upsert(WorldObject("w_near", "water_source", at(100)))
    store.upsert(WorldObject("b1", "base", at(50)))
    store.upsert(WorldObject("nowhere", "water_source"))
    found = store.near(BASE, 1000, kind="water_source")
    assert ids(found) == ["w_near", "w_far"]
    assert found[0][1] == pytest.approx(100, rel=1e-3)
    assert found[1][1] == pytest.approx(900, rel=1e-3)
    assert ids(store.near(BASE, 60)) == ["b1"]
    assert store.near(BASE, 10) == []


def area_world(store: WorldStore) -> None:
    """A 1 km square zone at BASE, things inside, across and outside it."""
    store.upsert(obj("zone", "zone", geometry=square(0, 0, 1000)))
    store.upsert(obj("inner", "zone", geometry=square(200, 200, 100)))
    store.upsert(obj("across", "zone", geometry=square(900, 900, 300)))
    store.upsert(obj("far", "zone", geometry=square(3000, 0, 100)))
    store.upsert(obj("road", "road", geometry=line((-500, 500), (1500, 500))))
    store.upsert(obj("track", "road", geometry=line((1200, 0), (1200, 1000))))
    store.upsert(WorldObject("uav_in", "robot", at(500, 500)))
    store.upsert(WorldObject("uav_out", "robot", at(1400, 500)))
    store.upsert(WorldObject("edge", "robot", at(0, 500)))  # on the boundary


def test_intersecting_and_within_agree_on_every_backend(open_store: StoreFactory) -> None:
    store = open_store()
    area_world(store)
    zone = Geometry.from_json(square(0, 0, 1000))
    assert ids(store.intersecting(zone)) == ["across", "edge", "inner", "road", "uav_in",
                                            "zone"]
    assert ids(store.intersecting(zone, kind="robot")) == ["edge", "uav_in"]
    # Within: inside, not merely touching the boundary; a shape is within itself.
    assert ids(store.within(zone)) == ["inner", "uav_in", "zone"]
    assert ids(store.within(Geometry.from_json(square(-10, -10, 5000)), kind="road")) == [
        "track"]
    crossing = Geometry.from_json(line((500, -100), (500, 2000)))
    assert ids(store.intersecting(crossing)) == ["road", "uav_in", "zone"]


def test_within_distance_measures_metres_to_lines_and_areas(open_store: StoreFactory) -> None:
    store = open_store()
    area_world(store)
    probe = Geometry.point(*north(500, -300))  # 300 m west of the zone's west edge
    found = store.within_distance(probe, 350)
    assert ids(found) == ["zone"] and found[0][1] == pytest.approx(300, rel=2e-3)
    assert ids(store.within_distance(probe, 290)) == []
    track = store.within_distance(Geometry.from_json(square(0, 0, 1000)), 250, kind="road")
    assert ids(track) == ["road", "track"]
    assert track[0][1] == 0.0 and track[1][1] == pytest.approx(200, rel=2e-3)
    # From an area to points: 0 inside, the gap outside. (On the boundary PostGIS's
    # great-circle edges and the embedded straight ones differ by millimetres.)
    robots = store.within_distance(Geometry.from_json(square(0, 0, 1000)), 500, "robot")
    assert sorted((o.id, round(d)) for o, d in robots) == [
        ("edge", 0), ("uav_in", 0), ("uav_out", 400)]
    on_road = Geometry.point(*north(-200, 500))
    assert store.within_distance(on_road, 100) == [(store.get("road"), 0.0)]


def test_rules_see_the_same_world_on_every_backend(open_store: StoreFactory) -> None:
    emitted: list[str] = []
    rules = RuleEngine([NoObjectWithin("hotspot", "water_source", 500, "hotspot_detected")])
    world = WorldModel(open_store(), rules, emitted.append)
    world.upsert(WorldObject("lake", "water_source", at(2000)))
    world.upsert(WorldObject("h1", "hotspot", BASE))
    world.upsert(WorldObject("h2", "hotspot", at(1700)))
    # Water drawn as an area counts by its nearest point.
    world.upsert(obj("pond", "water_source", geometry=square(4800, -100, 200)))
    world.upsert(WorldObject("h3", "hotspot", at(5400)))  # 400 m north of the pond
    world.upsert(WorldObject("h4", "hotspot", at(5600)))  # 600 m
    assert [e.split(",")[0] for e in emitted] == ["hotspot_detected(h1",
                                                  "hotspot_detected(h4"]


def test_bus_predicates_answer_and_refuse_bad_geometry(open_store: StoreFactory) -> None:
    world = WorldModel(open_store())
    area_world(world.store)
    zone = square(0, 0, 1000)
    assert [o["id"] for o in world.call("wm.within", [zone, "robot"])] == ["uav_in"]
    assert [o["id"] for o in world.call("wm.intersecting", [zone, "road"])] == ["road"]
    near = world.call("wm.within_distance", [zone, 450, "robot"])
    assert sorted(o["id"] for o in near[:2]) == ["edge", "uav_in"]
    assert near[2]["id"] == "uav_out" and near[2]["distance_m"] == pytest.approx(400, rel=2e-3)
    bad = {"type": "Polygon", "coordinates": [[[0, 0], [1, 1], [1, 0], [0, 1], [0, 0]]]}
    reply = world.handle(DataRequest(request_id="r1", function="wm.within", args=[bad]))
    assert not reply.ok and "Self-intersection" in str(reply.error)
    reply = world.handle(DataRequest(request_id="r2", function="wm.upsert", args=[
        {"id": "z9", "kind": "zone", "geometry": bad}]))
    assert not reply.ok and "'z9'" in str(reply.error) and world.get("z9") is None


def test_concurrent_writers_lose_no_update(open_store: StoreFactory) -> None:
    store = open_store()
    store.upsert(WorldObject("c", "counter", None, {}))

    def writer(n: int) -> None:
        for i in range(20):
            store.upsert(WorldObject("c", "counter", None, {f"w{n}_{i}": i}))
    threads = [threading.Thread(target=writer, args=(n,)) for n in range(3)]
    for t in threads:
        t.start()
    for t in threads:
        t.join()
    got = store.get("c")
    assert got is not None and len(got.attributes) == 60 and got.version == 61


SQUARE = [[0, 0], [0, 1], [1, 1], [1, 0], [0, 0]]


@pytest.mark.parametrize(("geometry", "reason"), [
    ({"type": "Polygon", "coordinates": [[[0, 0], [0, 1], [1, 1], [1, 0]]]}, "not closed"),
    ({"type": "Polygon", "coordinates": [[[0, 0], [1, 1], [1, 0], [0, 1], [0, 0]]]},
     "Self-intersection"),
    ({"type": "Polygon", "coordinates": [[[0, 0], [0, 1], [0, 0], [0, 0]]]}, "not valid"),
    ({"type": "LineString", "coordinates": [[0, 0], [0, float("nan")]]}, "finite"),
    ({"type": "LineString", "coordinates": [[0, 0], [0, 0]]}, "two distinct"),
    ({"type": "LineString", "coordinates": [[0, 0]]}, "2 to"),
    ({"type": "Point", "coordinates": [0, 91]}, r"lat 91.0 is outside \[-90, 90\]"),
    ({"type": "Point", "coordinates": [181, 0]}, r"lon 181.0 is outside"),
    ({"type": "Point", "coordinates": [1]}, r"\[lon, lat\]"),
    ({"type": "Point", "coordinates": ["1", 2]}, "must be a number"),
    ({"type": "MultiPolygon", "coordinates": [[SQUARE]]}, "not one of"),
    ({"type": "Polygon"}, "needs coordinates"),
    ({"type": "Polygon", "coordinates": [SQUARE], "crs": 4326}, "not a named coordinate"),
    ({"type": "Polygon", "coordinates": [SQUARE],
      "crs": {"type": "name", "properties": {"name": "EPSG:3857"}}},
     "crs 'EPSG:3857' is the wrong SRID: the world model takes WGS84 lon/lat only"),
    ({"type": "Point", "coordinates": [500_000.0, 4_400_000.0]}, "projected coordinates"),
    ({"type": "Polygon", "coordinates": [SQUARE], "bbox": [0, 0, 1, 1]}, "unknown key"),
    ([1, 2], "GeoJSON object"),
])
def test_bad_geometry_is_refused_naming_the_object(geometry: Any, reason: str) -> None:
    with pytest.raises(ValueError, match=reason) as caught:
        WorldObject.from_json({"id": "area7", "kind": "zone", "geometry": geometry})
    assert str(caught.value).startswith("object 'area7': geometry: ")
    world = WorldModel(SqliteWorldStore())
    with pytest.raises(ConfigError, match=r"object #1: object 'area7': geometry"):
        world.seed([{"id": "ok", "kind": "zone", "geometry": {"type": "Polygon",
                                                              "coordinates": [SQUARE]}},
                    {"id": "area7", "kind": "zone", "geometry": geometry}])


def test_a_wgs84_crs_is_accepted_and_a_wrong_srid_refused_by_both_backends(
        open_store: StoreFactory) -> None:
    world = WorldModel(open_store())
    named = {"type": "name", "properties": {"name": "urn:ogc:def:crs:OGC:1.3:CRS84"}}
    reply = world.handle(DataRequest(request_id="r1", function="wm.upsert", args=[
        {"id": "z1", "kind": "zone", "geometry": {"type": "Polygon",
                                                  "coordinates": [SQUARE], "crs": named}}]))
    assert reply.ok, reply.error
    stored = world.get("z1")
    assert stored is not None and stored.geometry is not None
    assert stored.geometry.to_json() == {"type": "Polygon", "coordinates": [SQUARE]}
    mercator = {"type": "name", "properties": {"name": "EPSG:3857"}}
    reply = world.handle(DataRequest(request_id="r2", function="wm.upsert", args=[
        {"id": "z2", "kind": "zone", "geometry": {"type": "Polygon",
                                                  "coordinates": [SQUARE], "crs": mercator}}]))
    assert not reply.ok and "object 'z2'" in str(reply.error)
    assert "wrong SRID" in str(reply.error) and world.get("z2") is None


def test_a_position_and_a_geometry_together_are_refused() -> None:
    with pytest.raises(ValueError, match="'both1': give position or geometry, not both"):
        WorldObject.from_json({"id": "both1", "kind": "zone", "position": {"lat": 0, "lon": 0},
                               "geometry": {"type": "Polygon", "coordinates": [SQUARE]}})


def test_a_long_diagonal_path_among_many_zones_finds_exactly_the_crossed_ones(
        open_store: StoreFactory) -> None:
    """The box of a long diagonal covers most zones (the embedded store then tests the
    candidates' boxes against the line itself): the answers are still exact."""
    store = open_store()
    zones = {f"z{n:03d}": square(200 * (n // 10), 200 * (n % 10), 60) for n in range(100)}
    for oid, shape in zones.items():
        store.upsert(obj(oid, "no_go", geometry=shape))
    store.upsert(WorldObject("crew1", "crew", at(1030, 930)))
    path = line((0, 0), (1900, 1800))
    crossing = sorted(oid for oid, shape in zones.items()
                      if Geometry.from_json(shape).shape.intersects(
                          Geometry.from_json(path).shape))
    assert len(crossing) >= 5
    assert ids(store.intersecting(Geometry.from_json(path), "no_go")) == crossing
    near = store.within_distance(Geometry.from_json(path), 30, "no_go")
    assert set(crossing) <= set(ids(near)) and len(near) < 40
    assert all(d <= 30.0 + 1e-6 for _, d in near)
    assert ids(store.within_distance(Geometry.from_json(path), 60, "crew")) == ["crew1"]
    assert store.within_distance(Geometry.from_json(path), 10, "crew") == []


def test_a_long_query_line_is_cut_into_pieces_that_are_the_same_line() -> None:
    from mrss.actors.worldmodel.postgis import MAX_PIECES, PIECE_DEG, line_pieces

    short = Geometry.from_json(line((0, 0), (500, 500)))
    assert line_pieces(short) is None
    assert line_pieces(Geometry.from_json(square(0, 0, 5000))) is None
    bent = Geometry.from_json({"type": "LineString",
                               "coordinates": [[1.0, 43.0], [1.045, 43.0], [1.045, 43.002]]})
    pieces = [json.loads(p)["coordinates"] for p in line_pieces(bent) or []]
    assert len(pieces) == 6                       # 5 for the 0.045 degree leg, 1 more
    assert pieces[0][0] == [1.0, 43.0] and pieces[-1][1] == [1.045, 43.002]
    assert [1.045, 43.0] in [p[1] for p in pieces]  # the bend is kept exactly
    assert all(a[1] == b[0] for a, b in zip(pieces, pieces[1:], strict=False))
    assert all(math.dist(*p) <= PIECE_DEG + 1e-12 for p in pieces)
    huge = Geometry.from_json({"type": "LineString", "coordinates": [[0.0, 0.0], [5.0, 5.0]]})
    assert len(line_pieces(huge) or []) == MAX_PIECES


def test_the_sqlite_store_upserts_over_what_is_stored_even_when_another_writer_came_first(
        tmp_path: Any) -> None:
    """SQLite keeps the points it wrote in memory (no read before each upsert); what
    another connection wrote, and what a failed batch rolled back, must still count."""
    path = tmp_path / "world.db"
    ours, theirs = SqliteWorldStore(path), SqliteWorldStore(path)
    try:
        ours.upsert(obj("uav1", "robot", position={"lat": 1.0, "lon": 2.0},
                        attributes={"battery": 90}))
        theirs.upsert(obj("uav1", "robot", attributes={"tank": 5}))  # version 2
        change = ours.upsert(obj("uav1", "robot", attributes={"battery": 80}))
        assert (change.op, change.obj.version) == ("update", 3)
        assert change.obj.attributes == {"battery": 80, "tank": 5}
        # A batch that fails half-way is rolled back whole; the next upsert merges with
        # the stored object, not with the rolled-back one.
        bad = WorldObject("uav1", "robot", Position(1.0, 2.0), {"battery": 70})
        with pytest.raises(AttributeError):  # not an object: fails after `bad` is written
            ours.upsert_many([bad, cast(WorldObject, None)])
        assert theirs.get("uav1").attributes["battery"] == 80  # type: ignore[union-attr]
        again = ours.upsert(obj("uav1", "robot", attributes={"battery": 80}))
        assert (again.op, again.obj.version) == ("unchanged", 3)
        # Attributes that JSON gives back otherwise (a tuple comes back as a list) are
        # compared as stored: the same list again changes nothing.
        ours.upsert(WorldObject("ugv1", "robot", Position(1.0, 2.0), {"path": (1, 2)}))
        same = ours.upsert(WorldObject("ugv1", "robot", Position(1.0, 2.0), {"path": [1, 2]}))
        assert same.op == "unchanged"
        assert ours.delete("ugv1")
        assert ours.upsert(obj("ugv1", "robot")).op == "insert"
        assert theirs.get("uav1") == ours.get("uav1")
    finally:
        ours.close()
        theirs.close()
