"""Lawnmower coverage of a polygon: the waypoints a UAV flies to see all of an area.

Lanes run west-east, `spacing` metres apart (less than the camera footprint's
diameter, so neighbouring lanes overlap), alternating direction. Each lane spans the
polygon from its first to its last crossing at that latitude (a concave area is flown
across its gaps). Flat-earth geometry around the polygon's centre: fine for areas of a
few kilometres.
"""

from __future__ import annotations

import math
from collections.abc import Sequence

from mrss.api import EARTH_RADIUS_M, offset

Point = tuple[float, float]


def to_local(lat0: float, lon0: float, lat: float, lon: float) -> Point:
    """(east, north) metres of (lat, lon) from (lat0, lon0)."""
    north = math.radians(lat - lat0) * EARTH_RADIUS_M
    east = math.radians(lon - lon0) * EARTH_RADIUS_M * math.cos(math.radians(lat0))
    return east, north


def lane_span(polygon: Sequence[Point], y: float) -> tuple[float, float] | None:
    """The west-most and east-most crossing of the line north = y with the polygon."""
    xs = []
    for i, (x1, y1) in enumerate(polygon):
        x2, y2 = polygon[(i + 1) % len(polygon)]
        if (y1 <= y < y2) or (y2 <= y < y1):
            xs.append(x1 + (y - y1) * (x2 - x1) / (y2 - y1))
    if len(xs) < 2:
        return None
    return min(xs), max(xs)


def lawnmower(polygon: Sequence[Sequence[float]], spacing: float) -> list[list[float]]:
    """Waypoints [[lat, lon], ...] sweeping `polygon` ([[lat, lon], ...]) lane by lane."""
    if len(polygon) < 3:
        raise ValueError("a polygon needs at least 3 vertices")
    if spacing <= 0:
        raise ValueError("lane spacing must be positive")
    lat0 = sum(p[0] for p in polygon) / len(polygon)
    lon0 = sum(p[1] for p in polygon) / len(polygon)
    local = [to_local(lat0, lon0, float(p[0]), float(p[1])) for p in polygon]
    south = min(y for _, y in local)
    north = max(y for _, y in local)
    lanes = max(1, math.ceil((north - south) / spacing))
    step = (north - south) / lanes
    waypoints: list[list[float]] = []
    for k in range(lanes):
        y = south + step * (k + 0.5)
        span = lane_span(local, y)
        if span is None:
            continue
        west, east = span
        ends = (west, east) if k % 2 == 0 else (east, west)
        for x in ends:
            lat, lon = offset(lat0, lon0, y, x)
            waypoints.append([round(lat, 7), round(lon, 7)])
    if not waypoints:
        raise ValueError("the polygon has no area to cover")
    return waypoints
