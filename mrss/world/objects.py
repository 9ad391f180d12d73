"""What the world model holds: objects with id, kind, a shape and JSON attributes.

Objects are robots, areas, hotspots, bases, zones, water sources ... — any kind that is a
lowercase identifier. A point object has a `position` (lat, lon, alt in degrees and
metres); a line or an area has a `geometry` (GeoJSON LineString or Polygon, see
`mrss.world.geometry`); an object may have neither. Attributes are a JSON
object. `merge` is how every backend applies an upsert and reports the `Change` that
rules react to.
"""

from __future__ import annotations

import json
import math
import re
import time
from collections.abc import Mapping
from dataclasses import dataclass, field
from typing import Any, Literal

from shapely.geometry import Point
from shapely.geometry.base import BaseGeometry

from mrss.world.geometry import Geometry, GeometryType, haversine_m

_KIND_RE = re.compile(r"[a-z][a-z0-9_]{0,63}\Z")
MAX_ID = 200

ChangeOp = Literal["insert", "update", "unchanged"]


_JSON_SCALARS = (str, int, bool, type(None))


def _plain_scalars(attributes: dict[str, Any]) -> bool:
    """Whether every key is a str and every value a str, int, bool, None or finite float
    (exactly these types): such attributes are plain JSON, as `json.dumps(...,
    allow_nan=False)` would find at a greater cost."""
    for key, value in attributes.items():
        if type(key) is not str:
            return False
        kind = type(value)
        if kind is float:
            if not math.isfinite(value):
                return False
        elif kind not in _JSON_SCALARS:
            return False
    return True


def _finite(value: Any, name: str) -> float:
    if isinstance(value, bool) or not isinstance(value, (int, float)):
        raise ValueError(f"{name} must be a number, not {type(value).__name__}")
    if not math.isfinite(value):
        raise ValueError(f"{name} must be finite")
    return float(value)


@dataclass(frozen=True)
class Position:
    """A WGS84 position: latitude and longitude in degrees, altitude in metres."""

    lat: float
    lon: float
    alt: float = 0.0

    def __post_init__(self) -> None:
        lat, lon = _finite(self.lat, "lat"), _finite(self.lon, "lon")
        _finite(self.alt, "alt")
        if not -90.0 <= lat <= 90.0:
            raise ValueError(f"lat {lat} is outside [-90, 90]")
        if not -180.0 <= lon <= 180.0:
            raise ValueError(f"lon {lon} is outside [-180, 180]")

    def distance_m(self, other: Position) -> float:
        """Ground distance to `other` in metres (altitude ignored)."""
        return haversine_m(self.lat, self.lon, other.lat, other.lon)

    def geometry(self) -> Geometry:
        """This position as a GeoJSON Point (altitude dropped)."""
        return Geometry(GeometryType.POINT, (self.lon, self.lat))

    @classmethod
    def from_json(cls, value: Any) -> Position | None:
        """`{"lat": .., "lon": .., "alt": ..}` or null; ValueError for anything else."""
        if value is None:
            return None
        if not isinstance(value, Mapping):
            raise ValueError("position must be an object with lat and lon")
        extra = set(value) - {"lat", "lon", "alt"}
        if extra:
            raise ValueError(f"position has unknown key(s) {sorted(extra)}")
        if "lat" not in value or "lon" not in value:
            raise ValueError("position needs lat and lon")
        return cls(_finite(value["lat"], "lat"), _finite(value["lon"], "lon"),
                   _finite(value.get("alt", 0.0), "alt"))


@dataclass(frozen=True)
class WorldObject:
    """One object of the world model: a point (`position`), a line or area (`geometry`),
    or no shape at all."""

    id: str
    kind: str
    position: Position | None = None
    attributes: dict[str, Any] = field(default_factory=dict)
    version: int = 0
    updated: float = 0.0
    geometry: Geometry | None = None

    def __post_init__(self) -> None:
        if not isinstance(self.id, str) or not self.id or len(self.id) > MAX_ID:
            raise ValueError(f"id must be a non-empty string of at most {MAX_ID} characters")
        if any(ord(c) < 32 or c == "/" for c in self.id):
            raise ValueError("id must not contain control characters or '/'")
        if not isinstance(self.kind, str) or not _KIND_RE.match(self.kind):
            raise ValueError(f"kind {self.kind!r} must be a lowercase identifier")
        if not isinstance(self.attributes, dict):
            raise ValueError("attributes must be an object")
        if self.geometry is not None and (
                self.position is not None or self.geometry.type is GeometryType.POINT):
            raise ValueError(f"object {self.id!r}: a point is a position; geometry is for "
                             "a LineString or a Polygon")
        if _plain_scalars(self.attributes):
            return  # plain JSON for sure (a robot's telemetry): no encoding to find out
        try:
            json.dumps(self.attributes, allow_nan=False)
        except (TypeError, ValueError) as exc:
            raise ValueError(f"attributes are not plain JSON: {exc}") from None

    @property
    def shape(self) -> BaseGeometry | None:
        """The object's shape in lon/lat degrees (shapely), or None."""
        if self.position is not None:
            return Point(self.position.lon, self.position.lat)
        return None if self.geometry is None else self.geometry.shape

    def shape_geometry(self) -> Geometry | None:
        """The object's shape as a Geometry (a point for a position), or None."""
        if self.position is not None:
            return self.position.geometry()
        return self.geometry

    def to_json(self) -> dict[str, Any]:
        """The object as served over HTTP and the bus (`geometry` null for a point)."""
        pos = None if self.position is None else {
            "lat": self.position.lat, "lon": self.position.lon, "alt": self.position.alt}
        return {"id": self.id, "kind": self.kind, "position": pos,
                "geometry": None if self.geometry is None else self.geometry.to_json(),
                "attributes": self.attributes, "version": self.version,
                "updated": self.updated}

    @classmethod
    def from_json(cls, value: Any) -> WorldObject:
        """Validate a client's object (`id`, `kind`, optional `position` or `geometry`,
        `attributes`). A GeoJSON Point geometry becomes the position."""
        if not isinstance(value, Mapping):
            raise ValueError("an object must be a JSON object")
        extra = set(value) - {"id", "kind", "position", "geometry", "attributes", "version",
                              "updated"}
        if extra:
            raise ValueError(f"unknown key(s) {sorted(extra)}")
        for key in ("id", "kind"):
            if key not in value:
                raise ValueError(f"missing {key!r}")
        name = value["id"]
        attributes = value.get("attributes", {})
        if not isinstance(attributes, dict):
            raise ValueError("attributes must be an object")
        try:
            position = Position.from_json(value.get("position"))
        except ValueError as exc:
            raise ValueError(f"object {name!r}: position: {exc}") from None
        geometry = None
        if value.get("geometry") is not None:
            try:
                geometry = Geometry.from_json(value["geometry"])
            except ValueError as exc:
                raise ValueError(f"object {name!r}: geometry: {exc}") from None
            if position is not None:
                raise ValueError(f"object {name!r}: give position or geometry, not both")
            if geometry.type is GeometryType.POINT:
                lon, lat, *alt = geometry.coordinates
                position, geometry = Position(lat, lon, alt[0] if alt else 0.0), None
        return cls(id=name, kind=value["kind"], position=position,
                   attributes=dict(attributes), geometry=geometry)


@dataclass(frozen=True)
class Change:
    """What an upsert did: the object now, and before (None for an insert)."""

    op: ChangeOp
    obj: WorldObject
    previous: WorldObject | None = None


def merge(obj: WorldObject, previous: WorldObject | None, *,
          replace_attributes: bool = False) -> Change:
    """The change an upsert of `obj` makes over `previous` (the stored object, or None).

    Attributes are merged unless replaced; an object with no shape keeps the stored one,
    a new position or geometry replaces it (a point may become an area).
    """
    if previous is None:
        new = _of_checked_parts(obj.id, obj.kind, obj.position, dict(obj.attributes), 1,
                                time.time(), obj.geometry)
        return Change("insert", new, None)
    attributes = dict(obj.attributes) if replace_attributes else {
        **previous.attributes, **obj.attributes}
    if obj.position is None and obj.geometry is None:
        position, geometry = previous.position, previous.geometry
    else:
        position, geometry = obj.position, obj.geometry
    if (obj.kind, position, geometry, attributes) == (
            previous.kind, previous.position, previous.geometry, previous.attributes):
        return Change("unchanged", previous, previous)
    new = _of_checked_parts(obj.id, obj.kind, position, attributes, previous.version + 1,
                            time.time(), geometry)
    return Change("update", new, previous)


_FIELDS = ("id", "kind", "position", "attributes", "version", "updated", "geometry")


def _of_checked_parts(*values: Any) -> WorldObject:
    """A WorldObject made of the parts of objects already checked (a merge of two of
    them is one too), without checking them again: a write of a moving robot made three
    objects and checked each, attributes encoded to JSON every time."""
    new = object.__new__(WorldObject)
    for name, value in zip(_FIELDS, values, strict=True):
        object.__setattr__(new, name, value)
    return new
