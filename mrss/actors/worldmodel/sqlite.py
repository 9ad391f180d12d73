"""The embedded world model store: objects in SQLite, spatial predicates with shapely.

Each row keeps the object's shape (position columns for a point, GeoJSON text for a
line or polygon) and its bounding box in degrees, kept in an R*Tree (`objects_box`, by
triggers) that prefilters the predicates in SQL; when that leaves many candidates (a
long diagonal path's box covers much of the world), their boxes are tested against the
query shape itself, all at once in shapely, before the survivors are read as objects
and shapely decides the predicate (`mrss.world.geometry` for the distance
method).
Safe to share between threads (the bus handler and the HTTP server): one lock serialises
every statement. An upsert merges with the stored object, which the store reads only
when it does not hold it already: it keeps the points it wrote (a moving robot's row is
not read before each of its updates) and forgets them all when another connection has
written the file or a write failed. The schema version is SQLite's `user_version`;
files of older versions are migrated when opened.
"""

from __future__ import annotations

import json
import math
import sqlite3
import threading
from pathlib import Path
from typing import Any

import shapely
from shapely.geometry.base import BaseGeometry

from mrss.sqlite_checkpoint import Checkpointer, manual_checkpoints
from mrss.world.geometry import (
    EARTH_RADIUS_M,
    Geometry,
    geometry_from_text,
    metric_distance_m,
)
from mrss.world.objects import Change, Position, WorldObject, merge

SCHEMA_VERSION = 3
_MIGRATIONS = {
    1: """
CREATE TABLE IF NOT EXISTS objects (
    id TEXT PRIMARY KEY, kind TEXT NOT NULL, lat REAL, lon REAL, alt REAL,
    attributes TEXT NOT NULL, version INTEGER NOT NULL, updated REAL NOT NULL);
CREATE INDEX IF NOT EXISTS objects_kind ON objects(kind);
""",
    2: """
ALTER TABLE objects ADD COLUMN geometry TEXT;
ALTER TABLE objects ADD COLUMN minlon REAL;
ALTER TABLE objects ADD COLUMN minlat REAL;
ALTER TABLE objects ADD COLUMN maxlon REAL;
ALTER TABLE objects ADD COLUMN maxlat REAL;
UPDATE objects SET minlon = lon, maxlon = lon, minlat = lat, maxlat = lat
    WHERE lat IS NOT NULL;
CREATE INDEX IF NOT EXISTS objects_bbox ON objects(minlat, maxlat);
""",
    3: """
DROP INDEX IF EXISTS objects_bbox;
CREATE VIRTUAL TABLE objects_box USING rtree(rid, minlon, maxlon, minlat, maxlat);
INSERT INTO objects_box SELECT rowid, minlon, maxlon, minlat, maxlat FROM objects
    WHERE minlon IS NOT NULL;
CREATE TRIGGER objects_box_insert AFTER INSERT ON objects WHEN new.minlon IS NOT NULL BEGIN
    INSERT INTO objects_box VALUES (new.rowid, new.minlon, new.maxlon, new.minlat, new.maxlat);
END;
CREATE TRIGGER objects_box_delete AFTER DELETE ON objects BEGIN
    DELETE FROM objects_box WHERE rid = old.rowid;
END;
CREATE TRIGGER objects_box_update AFTER UPDATE ON objects BEGIN
    DELETE FROM objects_box WHERE rid = old.rowid;
    INSERT INTO objects_box SELECT new.rowid, new.minlon, new.maxlon, new.minlat, new.maxlat
        WHERE new.minlon IS NOT NULL;
END;
""",
}
_COLUMNS = "id, kind, lat, lon, alt, attributes, version, updated, geometry"
_BOX_TEST_FROM = 32   # candidates from which their boxes are tested against the shape
_METRES_PER_DEGREE = EARTH_RADIUS_M * math.pi / 180
_KEPT_MAX = 10_000  # stored points kept in memory, to spare a read per upsert


class SqliteWorldStore:
    """SQLite-backed object store; `path` is a file, or ':memory:' for a throwaway one."""

    def __init__(self, path: str | Path = ":memory:", *, durable: bool = False) -> None:
        """A file is kept in WAL mode. Each write is one transaction; without `durable` it
        is synced to disk at checkpoints only (synchronous=NORMAL: a write survives the
        process being killed, the last ones may be lost to a power cut; ~6x the writes
        per second of a fleet's telemetry), with `durable` at every commit (FULL)."""
        self._lock = threading.Lock()
        self._checkpointer: Checkpointer | None = None
        self._db = sqlite3.connect(str(path), check_same_thread=False, isolation_level=None)
        # id -> the point object exactly as a read of its row would give it, so that an
        # upsert of a moving robot does not read its row first; dropped as a whole when
        # another connection has written the file (`data_version`) or a write rolls back.
        self._kept: dict[str, WorldObject] = {}
        self._data_version: int | None = None
        if str(path) != ":memory:":
            self._db.execute("PRAGMA journal_mode=WAL")
            self._db.execute(f"PRAGMA synchronous={'FULL' if durable else 'NORMAL'}")
            self._checkpointer = manual_checkpoints(self._db, path)  # off the write path
        self._migrate()

    def _migrate(self) -> None:
        (version,) = self._db.execute("PRAGMA user_version").fetchone()
        if version == 0 and self._db.execute(
                "SELECT 1 FROM sqlite_master WHERE name = 'objects'").fetchone():
            version = 1  # a file of the first release, before versions were recorded
        for step in range(version + 1, SCHEMA_VERSION + 1):
            self._db.executescript(f"BEGIN; {_MIGRATIONS[step]} PRAGMA user_version = {step};"
                                   " COMMIT;")

    def close(self) -> None:
        """Close the database."""
        if self._checkpointer is not None:
            self._checkpointer.close()
        with self._lock:
            self._db.close()

    def upsert(self, obj: WorldObject, *, replace_attributes: bool = False) -> Change:
        """Insert `obj`, or update the object with its id (`worldmodel_objects.merge`)."""
        with self._lock:
            self._check_kept()
            try:
                return self._upsert(obj, replace_attributes)
            except BaseException:
                self._kept.clear()
                raise

    def upsert_many(self, objs: list[WorldObject]) -> list[Change]:
        """Upsert `objs` in order in one transaction: all are committed or none (the
        error is raised after the rollback); returns once committed."""
        with self._lock:
            self._check_kept()
            self._db.execute("BEGIN")
            try:
                changes = [self._upsert(obj, False) for obj in objs]
                self._db.execute("COMMIT")
            except BaseException:
                self._kept.clear()
                if self._db.in_transaction:
                    self._db.execute("ROLLBACK")
                raise
            return changes

    def _check_kept(self) -> None:
        """Forget the kept objects if another connection wrote the file since (lock held)."""
        (version,) = self._db.execute("PRAGMA data_version").fetchone()
        if version != self._data_version:
            self._kept.clear()
            self._data_version = version

    def _upsert(self, obj: WorldObject, replace_attributes: bool) -> Change:
        previous = self._kept.get(obj.id)
        if previous is None:
            previous = self._get(obj.id)
        change = merge(obj, previous, replace_attributes=replace_attributes)
        if change.op == "unchanged":
            return change
        new = change.obj
        pos = new.position
        box = _box(new)
        attributes = json.dumps(new.attributes, allow_nan=False)
        self._db.execute(
            f"INSERT INTO objects ({_COLUMNS}, minlon, minlat, maxlon, maxlat)"
            " VALUES (?,?,?,?,?,?,?,?,?,?,?,?,?) ON CONFLICT (id) DO UPDATE SET "
            "kind = excluded.kind, lat = excluded.lat, lon = excluded.lon, "
            "alt = excluded.alt, attributes = excluded.attributes, "
            "version = excluded.version, updated = excluded.updated, "
            "geometry = excluded.geometry, minlon = excluded.minlon, "
            "minlat = excluded.minlat, maxlon = excluded.maxlon, maxlat = excluded.maxlat",
            (new.id, new.kind, pos.lat if pos else None, pos.lon if pos else None,
             pos.alt if pos else None, attributes, new.version, new.updated,
             None if new.geometry is None else new.geometry.to_text(), *box))
        self._keep(new, attributes)
        return change

    def _keep(self, new: WorldObject, attributes: str) -> None:
        """Keep `new` if a read of its row would give it back exactly: a point (or no
        shape) whose attributes come back from JSON as they are (not so a tuple)."""
        if new.geometry is None and _json_returns(new.attributes, attributes):
            if len(self._kept) >= _KEPT_MAX:
                self._kept.clear()
            self._kept[new.id] = new
        else:
            self._kept.pop(new.id, None)

    def get(self, object_id: str) -> WorldObject | None:
        """The object with this id, or None."""
        with self._lock:
            return self._get(object_id)

    def delete(self, object_id: str) -> bool:
        """Remove an object; False when there was none."""
        with self._lock:
            self._kept.pop(object_id, None)
            cur = self._db.execute("DELETE FROM objects WHERE id = ?", (object_id,))
            return cur.rowcount > 0

    def objects(self, kind: str | None = None) -> list[WorldObject]:
        """Every object, or those of one kind, ordered by id."""
        with self._lock:
            if kind is None:   # two statements: `? IS NULL OR` would hide the kind index
                cursor = self._db.execute(f"SELECT {_COLUMNS} FROM objects ORDER BY id")
            else:
                cursor = self._db.execute(
                    f"SELECT {_COLUMNS} FROM objects WHERE kind = ? ORDER BY id", (kind,))
            rows = cursor.fetchall()
        return [_row_object(r) for r in rows]

    def near(self, position: Position, radius_m: float,
             kind: str | None = None) -> list[tuple[WorldObject, float]]:
        """Objects within `radius_m` metres of `position`, nearest first, with distances."""
        return self.within_distance(position.geometry(), radius_m, kind)

    def intersecting(self, geometry: Geometry, kind: str | None = None) -> list[WorldObject]:
        """Objects whose shape shares a point with `geometry`, ordered by id."""
        query = geometry.shape
        return [o for o in self._candidates(kind, query.bounds, query)
                if o.shape is not None and o.shape.intersects(query)]

    def within(self, geometry: Geometry, kind: str | None = None) -> list[WorldObject]:
        """Objects whose shape lies inside `geometry`, ordered by id."""
        query = geometry.shape
        return [o for o in self._candidates(kind, query.bounds, query)
                if o.shape is not None and o.shape.within(query)]

    def within_distance(self, geometry: Geometry, distance_m: float,
                        kind: str | None = None) -> list[tuple[WorldObject, float]]:
        """Objects within `distance_m` metres of `geometry`, nearest first, with distances."""
        query = geometry.shape
        box = _expanded(query.bounds, distance_m)
        margin = max(query.bounds[0] - box[0], query.bounds[1] - box[1],
                     box[2] - query.bounds[2], box[3] - query.bounds[3])
        candidates = self._candidates(kind, box, query, margin)
        distances = metric_distance_m(query, [o.shape for o in candidates if o.shape])
        found = [(o, d) for o, d in zip(candidates, distances, strict=True)
                 if d <= distance_m]
        return sorted(found, key=lambda pair: (pair[1], pair[0].id))

    def _candidates(self, kind: str | None, box: tuple[float, float, float, float],
                    shape: BaseGeometry | None = None,
                    margin: float = 0.0) -> list[WorldObject]:
        """Objects whose box meets `box`; with `shape`, only those whose box comes
        within `margin` degrees of the shape itself (when there are many)."""
        minlon, minlat, maxlon, maxlat = box
        with self._lock:
            rows = self._db.execute(
                f"SELECT {_COLUMNS}, minlon, minlat, maxlon, maxlat FROM objects "
                "WHERE rowid IN (SELECT rid FROM objects_box "
                "WHERE maxlon >= ? AND minlon <= ? AND maxlat >= ? AND minlat <= ?) "
                "AND (? IS NULL OR kind = ?) ORDER BY id",
                (minlon, maxlon, minlat, maxlat, kind, kind)).fetchall()
        if shape is not None and len(rows) >= _BOX_TEST_FROM:
            boxes = shapely.box([r[9] for r in rows], [r[10] for r in rows],
                                [r[11] for r in rows], [r[12] for r in rows])
            near = shapely.dwithin(boxes, shape, margin) if margin > 0 else \
                shapely.intersects(boxes, shape)
            rows = [r for r, keep in zip(rows, near, strict=True) if keep]
        return [_row_object(r[:9]) for r in rows]

    def _get(self, object_id: str) -> WorldObject | None:
        row = self._db.execute(f"SELECT {_COLUMNS} FROM objects WHERE id = ?",
                               (object_id,)).fetchone()
        return None if row is None else _row_object(row)


def _expanded(box: tuple[float, float, float, float],
              metres: float) -> tuple[float, float, float, float]:
    """A lon/lat box holding every point within `metres` of `box` (generously)."""
    minlon, minlat, maxlon, maxlat = box
    dlat = metres * 1.01 / _METRES_PER_DEGREE + 1e-9
    low, high = max(-90.0, minlat - dlat), min(90.0, maxlat + dlat)
    widest = max(abs(low), abs(high))
    if widest >= 89.0 or dlat >= 45.0:
        return -180.0, low, 180.0, high
    dlon = dlat / math.cos(math.radians(widest))
    return max(-180.0, minlon - dlon), low, min(180.0, maxlon + dlon), high


_SCALARS = (str, int, float, bool, type(None))  # JSON gives these back as they are


def _json_returns(attributes: dict[str, Any], text: str) -> bool:
    """Whether `text` (the JSON of `attributes`) reads back as `attributes` itself."""
    if all(type(k) is str and type(v) in _SCALARS for k, v in attributes.items()):
        return True
    return bool(json.loads(text) == attributes)


def _box(obj: WorldObject) -> tuple[float | None, float | None, float | None, float | None]:
    """The object's lon/lat bounding box (a point's is itself: no shapely object made)."""
    pos = obj.position
    if pos is not None:
        return pos.lon, pos.lat, pos.lon, pos.lat
    shape = obj.shape
    return shape.bounds if shape is not None else (None, None, None, None)


def _row_object(row: Any) -> WorldObject:
    oid, kind, lat, lon, alt, attributes, version, updated, geometry = row
    position = None if lat is None else Position(lat, lon, alt or 0.0)
    return WorldObject(oid, kind, position, json.loads(attributes), version, updated,
                       None if geometry is None else geometry_from_text(geometry))
