"""The embedded world model: storage, distances, rules firing on inserts and updates."""

from __future__ import annotations

from collections.abc import Iterable
from pathlib import Path

import pytest

from mrss.actors.worldmodel.model import WorldModel, builtin_rule, load_rules, load_seed
from mrss.actors.worldmodel.rules import NoObjectWithin, RuleEngine, rule
from mrss.actors.worldmodel.store import (
    Change,
    Position,
    WorldModelStore,
    WorldObject,
    haversine_m,
)
from mrss.agentspeak.literals import literal, symbol
from mrss.errors import ConfigError
from mrss.messages import DataRequest
from tests.edge.termcheck import read_literal

BASE = Position(43.6045, 1.4440)


def offset_north(metres: float) -> Position:
    """A point `metres` north of BASE (1 degree of latitude is ~111.2 km)."""
    return Position(BASE.lat + metres / 111_194.9, BASE.lon)


def test_haversine_matches_known_distances() -> None:
    # Paris -> London is about 343.5 km great-circle.
    assert haversine_m(48.8566, 2.3522, 51.5074, -0.1278) == pytest.approx(343_500, rel=0.005)
    assert haversine_m(0, 0, 0, 0) == 0
    assert BASE.distance_m(offset_north(500)) == pytest.approx(500, rel=1e-3)


def test_store_inserts_merges_and_reports_changes(tmp_path: Path) -> None:
    store = WorldModelStore(tmp_path / "wm.sqlite")
    first = store.upsert(WorldObject("uav1", "robot", BASE, {"battery": 90}))
    assert first.op == "insert" and first.obj.version == 1 and first.previous is None
    same = store.upsert(WorldObject("uav1", "robot", None, {"battery": 90}))
    assert same.op == "unchanged"
    moved = store.upsert(WorldObject("uav1", "robot", offset_north(10), {"mode": "guided"}))
    assert moved.op == "update" and moved.obj.version == 2
    assert moved.obj.attributes == {"battery": 90, "mode": "guided"}
    assert moved.previous is not None and moved.previous.position == BASE
    store.close()
    reopened = WorldModelStore(tmp_path / "wm.sqlite")
    got = reopened.get("uav1")
    assert got is not None and got.position == offset_north(10) and got.version == 2
    assert [o.id for o in reopened.objects("robot")] == ["uav1"]
    assert reopened.objects("hotspot") == []
    assert reopened.delete("uav1") and not reopened.delete("uav1")


def test_near_orders_by_distance_and_filters_by_kind() -> None:
    store = WorldModelStore()
    store.upsert(WorldObject("w_far", "water_source", offset_north(900)))
    store.upsert(WorldObject("w_near", "water_source", offset_north(100)))
    store.upsert(WorldObject("b1", "base", offset_north(50)))
    store.upsert(WorldObject("nowhere", "water_source"))
    found = store.near(BASE, 1000, kind="water_source")
    assert [o.id for o, _ in found] == ["w_near", "w_far"]
    assert found[0][1] == pytest.approx(100, rel=1e-3)
    assert [o.id for o, _ in store.near(BASE, 60)] == ["b1"]


@pytest.mark.parametrize(("value", "reason"), [
    ({"kind": "robot"}, "missing 'id'"),
    ({"id": "", "kind": "robot"}, "id must be"),
    ({"id": "a/b", "kind": "robot"}, "'/'"),
    ({"id": "x", "kind": "Robot"}, "lowercase"),
    ({"id": "x", "kind": "robot", "position": {"lat": 91, "lon": 0}}, "outside"),
    ({"id": "x", "kind": "robot", "position": {"lat": 1}}, "lat and lon"),
    ({"id": "x", "kind": "robot", "position": {"lat": "1", "lon": 2}}, "number"),
    ({"id": "x", "kind": "robot", "attributes": [1]}, "attributes"),
    ({"id": "x", "kind": "robot", "colour": "red"}, "unknown key"),
    ([1, 2], "JSON object"),
])
def test_bad_objects_are_refused_with_a_reason(value: object, reason: str) -> None:
    with pytest.raises(ValueError, match=reason):
        WorldObject.from_json(value)


def hotspot_world(radius: float = 500) -> tuple[WorldModel, list[str]]:
    emitted: list[str] = []
    rules = RuleEngine([NoObjectWithin("hotspot", "water_source", radius, "hotspot_detected")])
    world = WorldModel(WorldModelStore(), rules, emitted.append)
    world.upsert(WorldObject("lake", "water_source", offset_north(2000)))
    return world, emitted


def test_hotspot_without_water_nearby_emits_hotspot_detected() -> None:
    world, emitted = hotspot_world()
    spot = offset_north(0)
    world.upsert(WorldObject("h1", "hotspot", spot, {"intensity": 3}))
    assert emitted == [literal("hotspot_detected", symbol("h1"), spot.lat, spot.lon)]
    assert read_literal(emitted[0]) == ("hotspot_detected", [("atom", "h1"), spot.lat,
                                                             spot.lon], [])
    # An update of the same hotspot is not a new detection.
    world.upsert(WorldObject("h1", "hotspot", spot, {"intensity": 4}))
    assert len(emitted) == 1


def test_hotspot_with_water_in_reach_emits_nothing() -> None:
    world, emitted = hotspot_world()
    world.upsert(WorldObject("h2", "hotspot", offset_north(1700)))  # lake 300 m away
    assert emitted == []
    # A hotspot id that is no atom still gives a safe literal (a string argument).
    world.upsert(WorldObject('H"3', "hotspot", offset_north(-10)))
    assert read_literal(emitted[0])[1][0] == 'H"3'


def test_failing_rule_is_counted_and_other_rules_still_fire() -> None:
    @rule(kind="robot")
    def broken(change: Change, world: WorldModelStore) -> Iterable[str]:
        raise RuntimeError("rule bug")

    @rule(kind="robot", ops=("update",))
    def moved(change: Change, world: WorldModelStore) -> Iterable[str]:
        yield literal("robot_moved", symbol(change.obj.id))

    @rule()
    def bad_text(change: Change, world: WorldModelStore) -> Iterable[str]:
        yield "not a literal("

    emitted: list[str] = []
    engine = RuleEngine([broken, moved, bad_text])
    world = WorldModel(WorldModelStore(), engine, emitted.append)
    world.upsert(WorldObject("ugv1", "robot", BASE))
    world.upsert(WorldObject("ugv1", "robot", offset_north(5)))
    assert emitted == ["robot_moved(ugv1)"]
    assert engine.errors == 4 and engine.fired == 1


def test_bus_functions_and_error_replies() -> None:
    world, emitted = hotspot_world()
    assert world.call("wm.upsert", [{"id": "h9", "kind": "hotspot",
                                     "position": {"lat": BASE.lat, "lon": BASE.lon}}])["op"] \
        == "insert"
    assert emitted and emitted[0].startswith("hotspot_detected(h9,")
    assert world.call("wm.get", ["h9"])["kind"] == "hotspot"
    assert world.call("wm.get", ["nope"]) is None
    assert [o["id"] for o in world.call("wm.list", ["water_source"])] == ["lake"]
    near = world.call("wm.near", [BASE.lat, BASE.lon, 2500, "water_source"])
    assert near[0]["id"] == "lake" and near[0]["distance_m"] == pytest.approx(2000, rel=1e-3)
    for function, args, reason in [("wm.get", [], "takes 1"), ("wm.get", [3], "string"),
                                   ("wm.fly", [], "unknown"), ("wm.upsert", [{"id": "x"}],
                                                               "kind"),
                                   ("wm.near", [0, 0, -1], "non-negative")]:
        reply = world.handle(DataRequest(request_id="r1", function=function, args=args))
        assert not reply.ok and reason in reply.error and reply.request_id == "r1"
    assert world.request_errors == 5


def test_config_rules_seed_and_project_rule_module(tmp_path: Path) -> None:
    (tmp_path / "world.json").write_text(
        '[{"id": "lake", "kind": "water_source", "position": {"lat": 43.6, "lon": 1.44}}]')
    (tmp_path / "worldmodel.py").write_text(
        "from mrss.actors.worldmodel.rules import rule\n"
        "@rule(kind='zone')\n"
        "def zone_seen(change, world):\n"
        "    yield 'zone_seen'\n"
        "def rules(options):\n"
        "    return [zone_seen]\n")
    options = {"seed": "world.json", "rules": [
        {"type": "no_object_within", "kind": "hotspot", "other": "water_source",
         "radius_m": 100}]}
    emitted: list[str] = []
    world = WorldModel(WorldModelStore(), RuleEngine(load_rules(tmp_path, options)),
                       emitted.append)
    assert load_seed(world, tmp_path, options) == 1
    world.upsert(WorldObject("h1", "hotspot", Position(43.7, 1.44)))
    world.upsert(WorldObject("z1", "zone"))
    assert emitted == ["hotspot_detected(h1,43.7,1.44)", "zone_seen"]


@pytest.mark.parametrize(("table", "reason"), [
    ({"type": "teleport"}, "unknown rule type"),
    ({"type": "no_object_within", "kind": "hotspot"}, "missing 'other'"),
    ({"type": "no_object_within", "kind": "h", "other": "w", "radius_m": "far"}, "far"),
])
def test_bad_rule_tables_are_config_errors(table: dict[str, object], reason: str) -> None:
    with pytest.raises(ConfigError, match=reason):
        builtin_rule(table, 0)


def test_seed_outside_the_project_or_malformed_is_refused(tmp_path: Path) -> None:
    world = WorldModel(WorldModelStore())
    with pytest.raises(ConfigError, match="outside the project"):
        load_seed(world, tmp_path, {"seed": "../elsewhere.json"})
    (tmp_path / "bad.json").write_text('[{"id": "x"}]')
    with pytest.raises(ConfigError, match="object #0"):
        load_seed(world, tmp_path, {"seed": "bad.json"})


def test_a_batch_of_writes_is_one_transaction_answered_per_object() -> None:
    world, emitted = hotspot_world()
    h1 = {"id": "h1", "kind": "hotspot", "position": {"lat": BASE.lat, "lon": BASE.lon}}
    robot = {"id": "r1", "kind": "robot", "position": {"lat": BASE.lat, "lon": BASE.lon},
             "attributes": {"n": 1}}
    moved = {**robot, "attributes": {"n": 2}}
    results = world.call("wm.upsert_many", [[h1, {"id": "x"}, robot, moved]], answer=False)
    assert [r.get("op") for r in results] == ["insert", None, "insert", "update"]
    assert "kind" in results[1]["error"]
    assert emitted and emitted[0].startswith("hotspot_detected(h1,")  # rules ran
    assert world.call("wm.get", ["r1"])["attributes"] == {"n": 2}
    answered = world.call("wm.upsert_many", [[{**robot, "attributes": {"n": 3}}]])
    assert answered[0]["object"]["attributes"] == {"n": 3}
    # A write failing in the store rolls the whole batch back: nothing of it is kept.
    unstorable = WorldObject("r3", "robot", BASE)
    unstorable.attributes["v"] = float("nan")  # past the object's check: SQL refuses it
    with pytest.raises(ValueError):
        world.upsert_many([WorldObject("r2", "robot", BASE), unstorable])
    assert world.get("r2") is None and world.get("r3") is None
    reply = world.handle(DataRequest(request_id="r9", function="wm.upsert_many",
                                     args=[{"id": "h1"}]))
    assert not reply.ok and "list of objects" in reply.error


def test_a_merge_makes_the_object_a_checked_construction_would() -> None:
    from dataclasses import fields

    from mrss.world.objects import _FIELDS, Position, WorldObject, merge

    assert tuple(f.name for f in fields(WorldObject)) == _FIELDS  # one per field, in order
    old = WorldObject("uav1", "robot", Position(1.0, 2.0), {"battery": 90}, 4, 10.0)
    change = merge(WorldObject("uav1", "robot", Position(1.5, 2.0), {"tank": 3}), old)
    made = change.obj
    assert made == WorldObject("uav1", "robot", Position(1.5, 2.0),
                               {"battery": 90, "tank": 3}, 5, made.updated)
    first = merge(WorldObject("ugv1", "robot", attributes={"a": 1}), None).obj
    assert first == WorldObject("ugv1", "robot", attributes={"a": 1}, version=1,
                                updated=first.updated)
