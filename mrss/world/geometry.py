"""Shapes of world model objects: GeoJSON-like points, lines and polygons, and metric distances.

On the API a shape is GeoJSON (coordinates are `[lon, lat]` or `[lon, lat, alt]`, degrees
WGS84): `{"type": "LineString", "coordinates": [[1.44, 43.60], [1.45, 43.61]]}`, or a
`Polygon` whose first ring is the outline and further rings are holes; every ring is
closed (last position = first). `Geometry.from_json` refuses anything else with a reason:
an unclosed or self-intersecting ring, a NaN, a latitude outside [-90, 90] or a
longitude outside [-180, 180], a `crs` other than WGS84 (the wrong SRID).

Topological predicates (intersects, within) are computed on lon/lat as a plane, as
PostGIS does for `geometry` columns. Distances are in metres on a sphere of the mean
Earth radius: `metric_distance_m` projects both shapes with an azimuthal equidistant
projection centred on the query shape's centre, where distances from the centre are
exact. To the middle of a line's or polygon's edge it agrees with PostGIS's great-circle
edges within 2e-6 up to 10 km, 2e-4 at 100 km and 0.4 % at 500 km (docs/edges.md).
"""

from __future__ import annotations

import json
import math
from collections.abc import Sequence
from dataclasses import dataclass
from enum import StrEnum
from functools import cached_property
from typing import Any

import shapely
from shapely.geometry import LineString, Point, Polygon
from shapely.geometry.base import BaseGeometry
from shapely.validation import explain_validity

EARTH_RADIUS_M = 6_371_008.8
MAX_POSITIONS = 10_000


class GeometryType(StrEnum):
    """The shapes an object can have."""

    POINT = "Point"
    LINESTRING = "LineString"
    POLYGON = "Polygon"


def haversine_m(lat1: float, lon1: float, lat2: float, lon2: float) -> float:
    """Great-circle distance in metres between two WGS84 points (spherical Earth)."""
    p1, p2 = math.radians(lat1), math.radians(lat2)
    dp, dl = p2 - p1, math.radians(lon2 - lon1)
    a = math.sin(dp / 2) ** 2 + math.cos(p1) * math.cos(p2) * math.sin(dl / 2) ** 2
    return 2 * EARTH_RADIUS_M * math.asin(min(1.0, math.sqrt(a)))


def _coordinate(value: Any, where: str) -> tuple[float, ...]:
    if not isinstance(value, (list, tuple)) or len(value) not in (2, 3):
        raise ValueError(f"{where} must be [lon, lat] or [lon, lat, alt], not {value!r}")
    out = []
    for name, number in zip(("lon", "lat", "alt"), value, strict=False):
        if isinstance(number, bool) or not isinstance(number, (int, float)):
            raise ValueError(f"{where}: {name} must be a number, not {number!r}")
        if not math.isfinite(number):
            raise ValueError(f"{where}: {name} must be finite, not {number}")
        out.append(float(number))
    hint = " (projected coordinates? they must be WGS84 lon/lat, EPSG:4326)"
    if not -180.0 <= out[0] <= 180.0:
        raise ValueError(f"{where}: lon {out[0]} is outside [-180, 180]{hint}")
    if not -90.0 <= out[1] <= 90.0:
        raise ValueError(f"{where}: lat {out[1]} is outside [-90, 90]{hint}")
    return tuple(out)


def _positions(value: Any, where: str, least: int) -> tuple[tuple[float, ...], ...]:
    if not isinstance(value, (list, tuple)):
        raise ValueError(f"{where} must be a list of positions")
    if not least <= len(value) <= MAX_POSITIONS:
        raise ValueError(f"{where} needs {least} to {MAX_POSITIONS} positions, "
                         f"has {len(value)}")
    return tuple(_coordinate(v, f"{where}[{i}]") for i, v in enumerate(value))


@dataclass(frozen=True)
class Geometry:
    """A validated shape: its type and GeoJSON coordinates (as tuples)."""

    type: GeometryType
    coordinates: Any

    @cached_property
    def shape(self) -> BaseGeometry:
        """The shapely geometry, x = lon and y = lat in degrees (made on first use)."""
        if self.type is GeometryType.POINT:
            return Point(self.coordinates[:2])
        if self.type is GeometryType.LINESTRING:
            return LineString([c[:2] for c in self.coordinates])
        return Polygon([c[:2] for c in self.coordinates[0]],
                       [[c[:2] for c in ring] for ring in self.coordinates[1:]])

    @classmethod
    def point(cls, lon: float, lat: float) -> Geometry:
        """A point (validated)."""
        return cls.from_json({"type": "Point", "coordinates": [lon, lat]})

    @classmethod
    def from_json(cls, value: Any) -> Geometry:
        """A GeoJSON Point, LineString or Polygon; ValueError saying what is wrong."""
        if not isinstance(value, dict):
            raise ValueError("geometry must be a GeoJSON object with type and coordinates")
        if "crs" in value:
            _check_crs(value["crs"])
        extra = set(value) - {"type", "coordinates", "crs"}
        if extra:
            raise ValueError(f"geometry has unknown key(s) {sorted(extra)}")
        try:
            kind = GeometryType(str(value.get("type")))
        except ValueError:
            raise ValueError(f"geometry type {value.get('type')!r} is not one of "
                             f"{[t.value for t in GeometryType]}") from None
        if "coordinates" not in value:
            raise ValueError("geometry needs coordinates")
        raw = value["coordinates"]
        coords: Any
        if kind is GeometryType.POINT:
            coords = _coordinate(raw, "Point coordinates")
        elif kind is GeometryType.LINESTRING:
            coords = _positions(raw, "LineString coordinates", 2)
            if len({c[:2] for c in coords}) < 2:
                raise ValueError("LineString needs two distinct positions")
        else:
            if not isinstance(raw, (list, tuple)) or not raw:
                raise ValueError("Polygon coordinates must be a list of rings (outline "
                                 "first, then holes)")
            coords = tuple(_ring(r, f"Polygon ring {i}") for i, r in enumerate(raw))
        geometry = cls(kind, coords)
        if not geometry.shape.is_valid:
            raise ValueError(f"{kind.value} is not valid: {explain_validity(geometry.shape)}")
        return geometry

    def to_json(self) -> dict[str, Any]:
        """GeoJSON."""
        return {"type": self.type.value, "coordinates": _lists(self.coordinates)}

    def to_text(self) -> str:
        """GeoJSON text, as stored."""
        return json.dumps(self.to_json(), allow_nan=False)


#: Names of WGS84 lon/lat, the only coordinate system a geometry may declare (`crs`).
WGS84_NAMES = frozenset({"EPSG:4326", "URN:OGC:DEF:CRS:EPSG::4326", "OGC:CRS84", "CRS84",
                         "URN:OGC:DEF:CRS:OGC:1.3:CRS84", "URN:OGC:DEF:CRS:OGC::CRS84"})


def _check_crs(value: Any) -> None:
    """A GeoJSON (2008) `crs` member: WGS84 is accepted (and dropped), anything else is
    refused naming it: coordinates are WGS84 lon/lat (SRID 4326) in both backends."""
    props = value.get("properties") if isinstance(value, dict) else None
    name = props.get("name") if isinstance(props, dict) else None
    if not isinstance(name, str):
        raise ValueError(f"geometry crs {value!r} is not a named coordinate system "
                         '({"type": "name", "properties": {"name": "EPSG:4326"}}); leave '
                         "crs out: coordinates are WGS84 lon/lat (EPSG:4326)")
    if name.strip().upper() not in WGS84_NAMES:
        raise ValueError(f"geometry crs {name!r} is the wrong SRID: the world model takes "
                         "WGS84 lon/lat only (EPSG:4326); reproject the coordinates")


def _ring(value: Any, where: str) -> tuple[tuple[float, ...], ...]:
    ring = _positions(value, where, 4)
    if ring[0][:2] != ring[-1][:2]:
        raise ValueError(f"{where} is not closed: its last position {list(ring[-1])} must "
                         f"repeat its first {list(ring[0])}")
    return ring


def _lists(value: Any) -> Any:
    if isinstance(value, tuple):
        return [_lists(v) for v in value]
    return value


def geometry_from_text(text: str) -> Geometry:
    """A stored geometry back (trusted: it was validated when written)."""
    value = json.loads(text)
    kind = GeometryType(value["type"])
    if kind is GeometryType.POINT:
        return Geometry(kind, tuple(value["coordinates"]))
    if kind is GeometryType.LINESTRING:
        return Geometry(kind, tuple(tuple(c) for c in value["coordinates"]))
    return Geometry(kind, tuple(tuple(tuple(c) for c in ring)
                                for ring in value["coordinates"]))


# --- metric distance ------------------------------------------------------------------


class AzimuthalProjection:
    """Azimuthal equidistant projection of the sphere around a centre (lon0, lat0), metres."""

    def __init__(self, lon0: float, lat0: float) -> None:
        self.lon0, self.lat0 = math.radians(lon0), math.radians(lat0)
        self._sin0, self._cos0 = math.sin(self.lat0), math.cos(self.lat0)

    def xy(self, lon: float, lat: float) -> tuple[float, float]:
        """Projected (east, north) metres of a point."""
        phi, dl = math.radians(lat), math.radians(lon) - self.lon0
        sin_p, cos_p = math.sin(phi), math.cos(phi)
        cos_c = self._sin0 * sin_p + self._cos0 * cos_p * math.cos(dl)
        c = math.acos(max(-1.0, min(1.0, cos_c)))
        if c < 1e-12:
            return 0.0, 0.0
        k = EARTH_RADIUS_M * c / math.sin(c) if c < math.pi - 1e-9 else EARTH_RADIUS_M * c
        return (k * cos_p * math.sin(dl),
                k * (self._cos0 * sin_p - self._sin0 * cos_p * math.cos(dl)))

    def project(self, geom: BaseGeometry) -> BaseGeometry:
        """The geometry in projected metres."""
        return shapely.transform(geom, self._xy_array)

    def _xy_array(self, points: Any) -> Any:
        out = points.copy()
        for i, (lon, lat) in enumerate(points):
            out[i] = self.xy(lon, lat)
        return out


def metric_distance_m(query: BaseGeometry, others: Sequence[BaseGeometry]) -> list[float]:
    """Distances in metres from `query` to each of `others` (0 where they touch)."""
    centre = query.centroid if not query.is_empty else Point(0, 0)
    projection = AzimuthalProjection(centre.x, centre.y)
    projected = projection.project(query)
    out: list[float] = []
    for other in others:
        if query.geom_type == "Point" and other.geom_type == "Point":
            out.append(haversine_m(query.y, query.x, other.y, other.x))
        elif query.intersects(other):
            out.append(0.0)
        else:
            out.append(float(projected.distance(projection.project(other))))
    return out
