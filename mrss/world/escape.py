"""The way out of a no-go zone: the shortest legal path for a robot found inside one.

A robot that stopped inside a zone it must not be in (a no-go zone) leaves it by the
nearest point of the zone's outline that lies outside every other such zone, on a
straight segment that meets no other zone, and ends `margin_m` beyond the outline (so
the point reached is outside, not on the edge). `shortest_exit` computes it in metres on
a local plane (an equirectangular projection around the robot: exact enough for zones of
a few kilometres), with shapely. Zones are GeoJSON polygons (`[lon, lat]`), as the world
model stores them.
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from typing import Any

import shapely
from shapely import ops
from shapely.geometry import LineString, Point, Polygon, shape
from shapely.geometry.base import BaseGeometry

from mrss.world.geometry import EARTH_RADIUS_M

#: Candidate exits tried along the outline when the nearest one's segment meets another
#: zone: one every this many metres.
STEP_M = 0.5


@dataclass(frozen=True)
class Exit:
    """Where a robot inside zone `zone` goes to leave it: `lat`, `lon`, `distance_m` away."""

    zone: str
    lat: float
    lon: float
    distance_m: float


class NoExit(ValueError):
    """The robot is inside a zone it cannot leave without entering another."""


class _Plane:
    """Metres east/north of an origin, and back."""

    def __init__(self, lat: float, lon: float) -> None:
        self.lat0, self.lon0 = lat, lon
        self.k = math.radians(1.0) * EARTH_RADIUS_M
        self.c = math.cos(math.radians(lat))

    def to_xy(self, geometry: BaseGeometry) -> BaseGeometry:
        def project(lonlat: Any) -> Any:
            out = lonlat.copy()
            out[:, 0] = (lonlat[:, 0] - self.lon0) * self.k * self.c
            out[:, 1] = (lonlat[:, 1] - self.lat0) * self.k
            return out
        return shapely.transform(geometry, project)

    def to_latlon(self, x: float, y: float) -> tuple[float, float]:
        return self.lat0 + y / self.k, self.lon0 + x / (self.k * self.c)


def shortest_exit(lat: float, lon: float, zones: Sequence[Mapping[str, Any]],
                  margin_m: float = 1.0) -> Exit | None:
    """The exit of the robot at `lat`, `lon` from the zone it is in, among `zones` (world
    model objects with `id` and a GeoJSON `geometry`); None when it is in none. NoExit when
    every way out meets another zone."""
    plane = _Plane(lat, lon)
    here = Point(0.0, 0.0)
    shapes = [(str(z.get("id", "")), plane.to_xy(shape(z["geometry"]))) for z in zones
              if isinstance(z.get("geometry"), Mapping)
              and z["geometry"].get("type") == "Polygon"]
    inside = [(zid, poly) for zid, poly in shapes if poly.covers(here)]
    if not inside:
        return None
    zid, zone = inside[0]
    blocked = ops.unary_union([p for i, p in shapes if i != zid] + [p for i, p in inside[1:]])
    # leave every zone the robot is in at once: the union of those it is inside
    area = ops.unary_union([p for _, p in inside])
    if not isinstance(area, Polygon):
        area = max(getattr(area, "geoms", [area]), key=lambda g: g.area)
    outside = area.buffer(margin_m)
    ring = LineString(outside.exterior.coords)
    free = ring.difference(blocked) if not blocked.is_empty else ring
    if free.is_empty:
        raise NoExit(f"every way out of zone {zid!r} meets another zone")
    nearest = ops.nearest_points(free, here)[0]
    target = _clear(here, nearest, free, blocked)
    if target is None:
        raise NoExit(f"every way out of zone {zid!r} crosses another zone")
    out_lat, out_lon = plane.to_latlon(target.x, target.y)
    return Exit(zid, out_lat, out_lon, here.distance(target))


def _clear(here: Point, nearest: Point, free: BaseGeometry,
           blocked: BaseGeometry) -> Point | None:
    """The nearest point of `free` whose straight segment from `here` meets no blocked
    zone: `nearest` itself when clear, else candidates along `free`, nearest first."""
    if blocked.is_empty or not LineString([here, nearest]).intersects(blocked):
        return nearest
    candidates: list[Point] = []
    for part in getattr(free, "geoms", [free]):
        steps = max(1, int(part.length / STEP_M))
        candidates += [part.interpolate(i / steps, normalized=True) for i in range(steps + 1)]
    for point in sorted(candidates, key=here.distance):
        if not LineString([here, point]).intersects(blocked):
            return point
    return None


def crossed(path: Sequence[tuple[float, float]], zones: Sequence[Mapping[str, Any]]
            ) -> list[str]:
    """Ids of the zones a path of (lat, lon) points meets (for tests and rules)."""
    line = LineString([(lon, lat) for lat, lon in path])
    return [str(z.get("id", "")) for z in zones
            if isinstance(z.get("geometry"), Mapping) and line.intersects(shape(z["geometry"]))]
