"""The way out of a no-go zone: the nearest legal point of its outline, never through
another zone (mrss.world.escape)."""

from __future__ import annotations

import pytest
from shapely.geometry import LineString, Point, shape

from mrss.api import distance_m
from mrss.world.escape import NoExit, crossed, shortest_exit

LAT, LON = 39.7700, 44.8000
D = 0.0001  # ~11 m of latitude, ~8.6 m of longitude here


def square(zid: str, south: float, west: float, north: float, east: float) -> dict:
    ring = [[LON + west * D, LAT + south * D], [LON + east * D, LAT + south * D],
            [LON + east * D, LAT + north * D], [LON + west * D, LAT + north * D],
            [LON + west * D, LAT + south * D]]
    return {"id": zid, "kind": "no_go", "geometry": {"type": "Polygon", "coordinates": [ring]}}


def test_a_robot_outside_every_zone_has_no_exit_to_take() -> None:
    assert shortest_exit(LAT + 50 * D, LON, [square("a", -1, -1, 1, 1)]) is None


def test_the_exit_is_the_nearest_point_of_the_outline_plus_the_margin() -> None:
    zone = square("marsh", -10, -10, 10, 1)  # the east edge is ~8.6 m away, others ~86+ m
    found = shortest_exit(LAT, LON, [zone], margin_m=1.0)
    assert found is not None and found.zone == "marsh"
    assert found.lat == pytest.approx(LAT, abs=1e-7)
    edge = distance_m(LAT, LON, LAT, LON + D)
    assert found.distance_m == pytest.approx(edge + 1.0, abs=0.05)
    assert distance_m(LAT, LON, found.lat, found.lon) == pytest.approx(found.distance_m,
                                                                         abs=0.05)
    assert not shape(zone["geometry"]).covers(Point(found.lon, found.lat))


def test_an_exit_next_to_another_zone_takes_the_nearest_way_that_stays_out_of_it() -> None:
    marsh = square("marsh", -10, -10, 10, 1)
    neighbour = square("crater", -20, 1, 20, 30)  # right behind the nearest (east) edge
    found = shortest_exit(LAT, LON, [marsh, neighbour], margin_m=1.0)
    assert found is not None
    path = [(LAT, LON), (found.lat, found.lon)]
    assert crossed(path, [neighbour]) == []
    assert not shape(marsh["geometry"]).covers(Point(found.lon, found.lat))
    # the next nearest edge is the west one, ~86 m; north and south are ~111 m
    assert found.distance_m == pytest.approx(distance_m(LAT, LON, LAT, LON - 10 * D) + 1.0,
                                             abs=0.6)
    assert not LineString([(LON, LAT), (found.lon, found.lat)]).intersects(
        shape(neighbour["geometry"]))


def test_a_zone_surrounded_by_others_has_no_exit() -> None:
    inner = square("inner", -1, -1, 1, 1)
    ring = [square("n", 1, -5, 5, 5), square("s", -5, -5, -1, 5),
            square("e", -5, 1, 5, 5), square("w", -5, -5, 5, -1)]
    with pytest.raises(NoExit, match="inner"):
        shortest_exit(LAT, LON, [inner, *ring])
