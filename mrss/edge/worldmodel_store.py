"""The embedded world model's storage: objects with id, kind, position and attributes in SQLite.

Objects are robots, areas, hotspots, bases, zones, water sources ... — any kind that is a
lowercase identifier. A position is (lat, lon, alt) in degrees and metres; attributes are
a JSON object. `upsert` reports what changed (`Change`), which is what rules react to.
Safe to share between threads (the bus handler and the HTTP server): one lock serialises
every statement.
"""

from __future__ import annotations

import json
import math
import re
import sqlite3
import threading
import time
from collections.abc import Mapping
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Literal

EARTH_RADIUS_M = 6_371_008.8
_KIND_RE = re.compile(r"[a-z][a-z0-9_]{0,63}\Z")
MAX_ID = 200

ChangeOp = Literal["insert", "update", "unchanged"]


def haversine_m(lat1: float, lon1: float, lat2: float, lon2: float) -> float:
    """Great-circle distance in metres between two WGS84 points (spherical Earth)."""
    p1, p2 = math.radians(lat1), math.radians(lat2)
    dp, dl = p2 - p1, math.radians(lon2 - lon1)
    a = math.sin(dp / 2) ** 2 + math.cos(p1) * math.cos(p2) * math.sin(dl / 2) ** 2
    return 2 * EARTH_RADIUS_M * math.asin(min(1.0, math.sqrt(a)))


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
    """One object of the world model."""

    id: str
    kind: str
    position: Position | None = None
    attributes: dict[str, Any] = field(default_factory=dict)
    version: int = 0
    updated: float = 0.0

    def __post_init__(self) -> None:
        if not isinstance(self.id, str) or not self.id or len(self.id) > MAX_ID:
            raise ValueError(f"id must be a non-empty string of at most {MAX_ID} characters")
        if any(ord(c) < 32 or c == "/" for c in self.id):
            raise ValueError("id must not contain control characters or '/'")
        if not isinstance(self.kind, str) or not _KIND_RE.match(self.kind):
            raise ValueError(f"kind {self.kind!r} must be a lowercase identifier")
        if not isinstance(self.attributes, dict):
            raise ValueError("attributes must be an object")
        try:
            json.dumps(self.attributes, allow_nan=False)
        except (TypeError, ValueError) as exc:
            raise ValueError(f"attributes are not plain JSON: {exc}") from None

    def to_json(self) -> dict[str, Any]:
        """The object as served over HTTP and the bus."""
        pos = None if self.position is None else {
            "lat": self.position.lat, "lon": self.position.lon, "alt": self.position.alt}
        return {"id": self.id, "kind": self.kind, "position": pos,
                "attributes": self.attributes, "version": self.version,
                "updated": self.updated}

    @classmethod
    def from_json(cls, value: Any) -> WorldObject:
        """Validate a client's object (`id`, `kind`, optional `position`, `attributes`)."""
        if not isinstance(value, Mapping):
            raise ValueError("an object must be a JSON object")
        extra = set(value) - {"id", "kind", "position", "attributes", "version", "updated"}
        if extra:
            raise ValueError(f"unknown key(s) {sorted(extra)}")
        for key in ("id", "kind"):
            if key not in value:
                raise ValueError(f"missing {key!r}")
        attributes = value.get("attributes", {})
        if not isinstance(attributes, dict):
            raise ValueError("attributes must be an object")
        return cls(id=value["id"], kind=value["kind"],
                   position=Position.from_json(value.get("position")),
                   attributes=dict(attributes))


@dataclass(frozen=True)
class Change:
    """What an upsert did: the object now, and before (None for an insert)."""

    op: ChangeOp
    obj: WorldObject
    previous: WorldObject | None = None


_SCHEMA = """
CREATE TABLE IF NOT EXISTS objects (
    id TEXT PRIMARY KEY, kind TEXT NOT NULL, lat REAL, lon REAL, alt REAL,
    attributes TEXT NOT NULL, version INTEGER NOT NULL, updated REAL NOT NULL);
CREATE INDEX IF NOT EXISTS objects_kind ON objects(kind);
"""
_COLUMNS = "id, kind, lat, lon, alt, attributes, version, updated"


class WorldModelStore:
    """SQLite-backed object store; `path` is a file, or ':memory:' for a throwaway one."""

    def __init__(self, path: str | Path = ":memory:") -> None:
        self._lock = threading.Lock()
        self._db = sqlite3.connect(str(path), check_same_thread=False, isolation_level=None)
        self._db.create_function("haversine_m", 4, haversine_m, deterministic=True)
        if str(path) != ":memory:":
            self._db.execute("PRAGMA journal_mode=WAL")
        self._db.executescript(_SCHEMA)

    def close(self) -> None:
        """Close the database."""
        with self._lock:
            self._db.close()

    def upsert(self, obj: WorldObject, *, replace_attributes: bool = False) -> Change:
        """Insert `obj`, or update the object with its id (attributes merged unless replaced).

        A position of None on update keeps the stored position.
        """
        with self._lock:
            previous = self._get(obj.id)
            if previous is None:
                new = WorldObject(obj.id, obj.kind, obj.position, dict(obj.attributes), 1,
                                  time.time())
                op: ChangeOp = "insert"
            else:
                attributes = dict(obj.attributes) if replace_attributes else {
                    **previous.attributes, **obj.attributes}
                position = obj.position if obj.position is not None else previous.position
                if (obj.kind, position, attributes) == (
                        previous.kind, previous.position, previous.attributes):
                    return Change("unchanged", previous, previous)
                new = WorldObject(obj.id, obj.kind, position, attributes,
                                  previous.version + 1, time.time())
                op = "update"
            pos = new.position
            self._db.execute(
                f"INSERT OR REPLACE INTO objects ({_COLUMNS}) VALUES (?,?,?,?,?,?,?,?)",
                (new.id, new.kind, pos.lat if pos else None, pos.lon if pos else None,
                 pos.alt if pos else None, json.dumps(new.attributes, allow_nan=False),
                 new.version, new.updated))
            return Change(op, new, previous)

    def get(self, object_id: str) -> WorldObject | None:
        """The object with this id, or None."""
        with self._lock:
            return self._get(object_id)

    def delete(self, object_id: str) -> bool:
        """Remove an object; False when there was none."""
        with self._lock:
            cur = self._db.execute("DELETE FROM objects WHERE id = ?", (object_id,))
            return cur.rowcount > 0

    def objects(self, kind: str | None = None) -> list[WorldObject]:
        """Every object, or those of one kind, ordered by id."""
        with self._lock:
            if kind is None:
                rows = self._db.execute(f"SELECT {_COLUMNS} FROM objects ORDER BY id")
            else:
                rows = self._db.execute(
                    f"SELECT {_COLUMNS} FROM objects WHERE kind = ? ORDER BY id", (kind,))
            return [_row_object(r) for r in rows.fetchall()]

    def near(self, position: Position, radius_m: float,
             kind: str | None = None) -> list[tuple[WorldObject, float]]:
        """Objects within `radius_m` metres of `position`, nearest first, with distances."""
        with self._lock:
            rows = self._db.execute(
                f"SELECT {_COLUMNS}, d FROM (SELECT *, haversine_m(lat, lon, ?, ?) AS d "
                "FROM objects WHERE lat IS NOT NULL AND (? IS NULL OR kind = ?)) "
                "WHERE d <= ? ORDER BY d, id",
                (position.lat, position.lon, kind, kind, radius_m)).fetchall()
            return [(_row_object(r[:8]), float(r[8])) for r in rows]

    def _get(self, object_id: str) -> WorldObject | None:
        row = self._db.execute(f"SELECT {_COLUMNS} FROM objects WHERE id = ?",
                               (object_id,)).fetchone()
        return None if row is None else _row_object(row)


def _row_object(row: Any) -> WorldObject:
    oid, kind, lat, lon, alt, attributes, version, updated = row
    position = None if lat is None else Position(lat, lon, alt or 0.0)
    return WorldObject(oid, kind, position, json.loads(attributes), version, updated)
