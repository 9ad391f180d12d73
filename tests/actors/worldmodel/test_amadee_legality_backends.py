"""Every AMADEE-24 legality rule on both world model backends: an illegal action never
reaches the robot.

The chain is the running system's, in one process: the project's agent.asl on the real
interpreter (a scripted host records every action it would send to the RCL), its
`query(legal, [A], V)` answered by the project's real data layer (datalayer.py, whose
rules ask the world model's spatial predicates), over a world model seeded with the
project's world.json in embedded SQLite or in PostGIS (the private server of
tests/actors/worldmodel/pgcluster.py; skipped without PostgreSQL 15 + PostGIS, failing instead when
MRSS_REQUIRE_POSTGIS=1, as in CI). For each rule: the refusal names the rule and the
geometry, the verdict is stored for the operator, and no action was sent; a legal
request in between is sent, so a layer that refused everything would fail.
"""

from __future__ import annotations

import json
import time
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from mrss.actors.datalayer.layer import DataLayerContext
from mrss.actors.worldmodel.local import LocalWorldModel
from mrss.actors.worldmodel.model import WorldModel
from mrss.api.testing import ScriptedHost
from mrss.runtime.loader import import_project_module
from tests.actors.worldmodel.stores import StoreFactory

PROJECT = Path(__file__).resolve().parents[3] / "projects" / "amadee"
HOME = (39.7700, 44.8000)


@dataclass(frozen=True)
class Case:
    """A request, the world it meets, and the rule that must refuse it."""

    rule: str
    percept: str                     # what the operator's request becomes
    action: str                      # what the agent would send
    rover: dict[str, Any] = field(default_factory=dict)   # lat, lon, speed, battery
    objects: tuple[dict[str, Any], ...] = ()              # upserted before, deleted after
    names: str = ""                  # the zone, crew, grid or window named in the detail


def _blackout() -> dict[str, Any]:
    now = time.time()
    iso = "%Y-%m-%dT%H:%M:%SZ"
    return {"id": "relay_pass", "kind": "time_window",
            "attributes": {"what": "comms blackout", "forbids": ["drive", "return_home"],
                           "start": time.strftime(iso, time.gmtime(now - 60)),
                           "end": time.strftime(iso, time.gmtime(now + 3600))}}


def _cases() -> list[Case]:
    return [
        Case("time_window", "drive_received(g1, 39.7705, 44.8)",
             "drive(rover1,g1,39.7705,44.8)", objects=(_blackout(),), names="'relay_pass'"),
        Case("no_go_path", "drive_received(g2, 39.7725, 44.801)",
             "drive(rover1,g2,39.7725,44.801)", names="'salt_marsh'"),
        Case("protected_path", "drive_received(g3, 39.768, 44.7985)",
             "drive(rover1,g3,39.768,44.7985)", names="'biosig_site'"),
        Case("communication_zone", "drive_received(g4, 39.774, 44.796)",
             "drive(rover1,g4,39.774,44.796)", names="400 m"),
        Case("crew_safety", "drive_received(g5, 39.77, 44.7982)",
             "drive(rover1,g5,39.77,44.7982)", names="'eva1'"),
        Case("slope_limit", "drive_received(g6, 39.77, 44.8036)",
             "drive(rover1,g6,39.77,44.8036)", names="'crater_rim'"),
        Case("battery_reserve", "drive_received(g7, 39.7715, 44.799)",
             "drive(rover1,g7,39.7715,44.799)", rover={"battery": 20.0},
             names="the battery has 20.0%"),
        Case("arm_when_stopped", "science_received(g8, sample)", "sample(rover1,g8)",
             rover={"lat": 39.7705, "speed": 0.8}, names="0.80 m/s"),
        Case("no_sampling_protected", "science_received(g9, sample)", "sample(rover1,g9)",
             rover={"lat": 39.7688, "lon": 44.7995}, names="'biosig_site'"),
        Case("time_window", "home_received(g10)", "return_home(rover1,g10)",
             rover={"lat": 39.7705}, objects=(_blackout(),), names="'relay_pass'"),
    ]


def _place(world: LocalWorldModel, lat: float = HOME[0], lon: float = HOME[1],
           speed: float = 0.0, battery: float = 100.0) -> None:
    world.upsert({"id": "rover1", "kind": "robot", "position": {"lat": lat, "lon": lon},
                  "attributes": {"speed": speed, "battery": battery}})


def test_every_rule_refuses_and_nothing_reaches_the_robot(open_store: StoreFactory) -> None:
    world = WorldModel(open_store())
    world.seed(json.loads((PROJECT / "world.json").read_text(encoding="utf-8")),
               source="world.json")
    datalayer_module = import_project_module(PROJECT, "datalayer.py")
    local = LocalWorldModel(world)
    data = datalayer_module.AmadeeData(DataLayerContext(world=local))
    host = ScriptedHost(answers={"legal": data.legal})
    agent = host.load(PROJECT / "agent.asl", name="amadee")
    rules = {c.rule for c in _cases()}
    assert rules == {r.__name__ for r in data_rules()}, "a rule without a case here"

    for n, case in enumerate(_cases()):
        _place(local, **case.rover)
        for obj in case.objects:
            local.upsert(obj)
        goal = case.action.split(",")[1].rstrip(")")
        mark = len(host.log)
        host.feed(case.percept)
        assert host.since(mark) == [f"query(legal,[{case.action}],V)"], case.rule
        assert agent.believes(f'refused({goal}, "{case.rule}")'), case.rule
        stored = world.get(f"verdict_{goal}")
        assert stored is not None, case.rule
        verdict = stored.attributes
        assert (verdict["legal"], verdict["rule"], verdict["action"]) == (
            False, case.rule, case.action)
        assert case.names in verdict["detail"], verdict
        assert verdict["geometry"] and verdict["geometry"]["type"] in (
            "Point", "LineString", "Polygon"), verdict
        for obj in case.objects:
            world.store.delete(obj["id"])

        # a legal request (the rover at home, a short drive in the open) is sent
        _place(local)
        mark = len(host.log)
        host.feed(f"drive_received(ok{n}, 39.7705, 44.8)")
        assert host.since(mark) == [f"query(legal,[drive(rover1,ok{n},39.7705,44.8)],V)",
                                    f"drive(rover1,ok{n},39.7705,44.8)"], case.rule
        host.finish(f"drive(rover1,ok{n},39.7705,44.8)")
    assert not host.open


def data_rules() -> tuple[Any, ...]:
    """The rules the project checks (legality.RULES)."""
    rules: tuple[Any, ...] = import_project_module(PROJECT, "legality.py").RULES
    return rules
