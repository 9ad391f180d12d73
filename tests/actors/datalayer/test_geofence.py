"""The data layer's geofence (mrss.actors.datalayer.geofence): a robot found stopped inside
a no-go zone is given its shortest legal way out as a percept, once; a trapped one is
told so; both are taken back when the robot is out. A real in-memory world model."""

from __future__ import annotations

import pytest

from mrss.actors.datalayer.geofence import EXIT, TRAPPED, Finding, Geofence
from mrss.api import distance_m, shortest_exit
from mrss.api.testing import memory_world
from mrss.errors import ConfigError
from mrss.messages import Percept
from mrss.runtime.percepts import PerceptPublisher

LAT, LON = 39.7700, 44.8000
D = 0.0001


def square(zid: str, south: float, west: float, north: float, east: float,
           kind: str = "no_go") -> dict:
    ring = [[LON + west * D, LAT + south * D], [LON + east * D, LAT + south * D],
            [LON + east * D, LAT + north * D], [LON + west * D, LAT + north * D],
            [LON + west * D, LAT + south * D]]
    return {"id": zid, "kind": kind, "geometry": {"type": "Polygon", "coordinates": [ring]}}


class Clock:
    def __init__(self) -> None:
        self.now = 100.0

    def __call__(self) -> float:
        return self.now


def fence(objects: list[dict], **options: object) -> tuple[Geofence, list[Percept], Clock]:
    sent: list[Percept] = []
    clock = Clock()
    world = memory_world(objects)
    found = Geofence.configured({"geofence": True, **options}, world,
                                PerceptPublisher(lambda p, _id: sent.append(p)))
    assert found is not None
    found.clock = clock
    return found, sent, clock


def at(lat: float, lon: float, speed: float | None = 0.0) -> dict:
    record: dict = {"type": "position", "lat": lat, "lon": lon}
    if speed is not None:
        record["speed"] = speed
    return record


def test_off_by_default_and_its_options_are_checked() -> None:
    world = memory_world([])
    publisher = PerceptPublisher(lambda p, _id: None)
    assert Geofence.configured({}, world, publisher) is None
    assert Geofence.configured({"geofence": True}, None, publisher) is None  # no world model
    with pytest.raises(ConfigError, match="datalayer.geofence_margin_m"):
        Geofence.configured({"geofence": True, "geofence_margin_m": 0}, world, publisher)


def test_a_robot_stopped_inside_is_given_the_nearest_way_out_once_then_it_is_taken_back(
        ) -> None:
    marsh = square("marsh", -10, -10, 10, 1)          # the east edge ~8.6 m away
    geofence, sent, clock = fence([marsh])
    assert geofence.observe("ugv1", at(LAT, LON, speed=1.5)) is Finding.MOVING
    assert sent == []
    clock.now += 1.0
    assert geofence.observe("ugv1", at(LAT, LON)) is Finding.EXIT
    way = shortest_exit(LAT, LON, [marsh])
    assert way is not None
    assert [p.literal for p in sent] == [
        f"{EXIT}(ugv1,marsh,{round(way.lat, 7)},{round(way.lon, 7)})"]
    assert distance_m(LAT, LON, way.lat, way.lon) == pytest.approx(
        distance_m(LAT, LON, LAT, LON + D) + 1.0, abs=0.05)
    clock.now += 1.0
    geofence.observe("ugv1", at(LAT, LON))             # still there: nothing new
    clock.now += 0.5
    assert geofence.observe("ugv1", at(LAT, LON)) is None   # not time to look yet
    assert len(sent) == 1
    clock.now += 1.0
    assert geofence.observe("ugv1", at(way.lat, way.lon)) is Finding.OUTSIDE
    assert [(p.op, p.literal) for p in sent[1:]] == [("remove", sent[0].literal)]


def test_a_robot_without_a_speed_is_stopped_when_its_fixes_stand_still() -> None:
    geofence, sent, clock = fence([square("marsh", -10, -10, 10, 1)],
                                  geofence_interval=0.5)
    assert geofence.observe("ugv1", at(LAT, LON, speed=None)) is Finding.MOVING  # first fix
    clock.now += 1.0
    assert geofence.observe("ugv1", at(LAT, LON, speed=None)) is Finding.EXIT
    assert sent[0].literal.startswith(f"{EXIT}(ugv1,marsh,")


def test_a_robot_boxed_in_by_other_zones_is_trapped_and_nothing_else_is_said() -> None:
    ring = [square("n", 1, -5, 5, 5), square("s", -5, -5, -1, 5),
            square("e", -5, 1, 5, 5), square("w", -5, -5, 5, -1)]
    geofence, sent, clock = fence([square("inner", -1, -1, 1, 1), *ring])
    assert geofence.observe("ugv1", at(LAT, LON)) is Finding.TRAPPED
    assert [p.literal for p in sent] == [f"{TRAPPED}(ugv1,inner)"]
    clock.now += 1.0
    assert geofence.observe("ugv1", at(LAT, LON)) is Finding.TRAPPED
    assert len(sent) == 1


def test_only_the_kinds_named_are_zones() -> None:
    geofence, sent, _ = fence([square("site", -10, -10, 10, 10, kind="protected")])
    assert geofence.observe("ugv1", at(LAT, LON)) is Finding.OUTSIDE and sent == []
    geofence, sent, _ = fence([square("site", -10, -10, 10, 10, kind="protected")],
                              geofence_kinds=["no_go", "protected"])
    assert geofence.observe("ugv1", at(LAT, LON)) is Finding.EXIT
    assert sent[0].literal.startswith(f"{EXIT}(ugv1,site,")


def test_a_zone_that_appears_around_a_leaving_robot_replaces_its_way_out() -> None:
    marsh = square("marsh", -10, -10, 10, 1)
    geofence, sent, clock = fence([marsh])
    geofence.observe("ugv1", at(LAT, LON))
    geofence.world.upsert(square("crater", -20, 1, 20, 30))   # right behind the east edge
    clock.now += 1.0
    assert geofence.observe("ugv1", at(LAT, LON)) is Finding.EXIT
    assert [p.op for p in sent] == ["add", "remove", "add"]
    assert sent[1].literal == sent[0].literal and sent[2].literal != sent[0].literal
    lon = float(sent[2].literal.rstrip(")").split(",")[3])
    assert lon < LON        # now west, away from the crater
