"""Small-area geodesy for links and simulators: distances and straight-line moves in metres."""

from __future__ import annotations

import math

EARTH_RADIUS_M = 6_371_000.0


def distance_m(lat1: float, lon1: float, lat2: float, lon2: float) -> float:
    """Great-circle distance in metres between two WGS84 points (haversine)."""
    p1, p2 = math.radians(lat1), math.radians(lat2)
    dp = p2 - p1
    dl = math.radians(lon2 - lon1)
    a = math.sin(dp / 2) ** 2 + math.cos(p1) * math.cos(p2) * math.sin(dl / 2) ** 2
    return 2 * EARTH_RADIUS_M * math.asin(min(1.0, math.sqrt(a)))


def bearing_deg(lat1: float, lon1: float, lat2: float, lon2: float) -> float:
    """Initial bearing from point 1 to point 2, degrees clockwise from north in [0, 360)."""
    p1, p2 = math.radians(lat1), math.radians(lat2)
    dl = math.radians(lon2 - lon1)
    y = math.sin(dl) * math.cos(p2)
    x = math.cos(p1) * math.sin(p2) - math.sin(p1) * math.cos(p2) * math.cos(dl)
    return math.degrees(math.atan2(y, x)) % 360.0


def offset(lat: float, lon: float, north_m: float, east_m: float) -> tuple[float, float]:
    """The point `north_m` north and `east_m` east of (lat, lon), flat-earth approximation."""
    dlat = math.degrees(north_m / EARTH_RADIUS_M)
    dlon = math.degrees(east_m / (EARTH_RADIUS_M * math.cos(math.radians(lat))))
    return lat + dlat, lon + dlon


def step_towards(
    lat: float, lon: float, target_lat: float, target_lon: float, max_step_m: float
) -> tuple[float, float]:
    """Move from (lat, lon) towards the target by at most `max_step_m`; land on it if closer."""
    remaining = distance_m(lat, lon, target_lat, target_lon)
    if remaining <= max_step_m or remaining == 0.0:
        return target_lat, target_lon
    fraction = max_step_m / remaining
    # Interpolating in degrees is accurate enough over the few km a simulated robot covers.
    return lat + (target_lat - lat) * fraction, lon + (target_lon - lon) * fraction


def approach(value: float, target: float, max_step: float) -> float:
    """Move a scalar towards `target` by at most `max_step`."""
    if abs(target - value) <= max_step:
        return target
    return value + math.copysign(max_step, target - value)
