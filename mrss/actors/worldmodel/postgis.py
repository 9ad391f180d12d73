"""The world model in PostgreSQL + PostGIS (psycopg 3), for a shared or large world.

Selected by `[worldmodel] url = "postgresql://user@host:5432/db"`. Every object's shape is
a `geometry(Geometry, 4326)` column with a GiST index on it and one on its `geography`
cast; predicates run in SQL: ST_Intersects and ST_Within on the geometry (lon/lat as a
plane, like the embedded store; a long query line intersects in pieces, each its own
index scan), ST_DWithin and ST_Distance on the geography with `use_spheroid = false`
(a sphere of the mean Earth radius, so both backends measure alike).
The GeoJSON the client sent is kept as text next to it and is what reads return.

The schema is created and migrated on connect, under an advisory lock, recorded in
`wm_schema_version` (idempotent: any number of processes may start at once).

One connection, serialised by a lock. When the server goes away, the request in flight
fails with `WorldStoreUnavailable` (a write in flight is not acknowledged, so it may or
may not have been stored); later requests reconnect, trying at most once per backoff
delay (0.1 s doubling to 5 s) and failing at once in between, so nothing waits on a dead
server. A request that gets no answer within `request_timeout` (a frozen server or
network) has its connection cut and fails the same way. An upsert returns only after its
transaction committed: an acknowledged write is durable in the server.
"""

from __future__ import annotations

import json
import logging
import math
import threading
import time
from collections.abc import Callable
from typing import Any, TypeVar
from urllib.parse import urlsplit

import psycopg
from psycopg.types.json import Jsonb

from mrss.actors.worldmodel.pgwatchdog import Watchdog
from mrss.actors.worldmodel.store import WorldStoreUnavailable
from mrss.actors.worldmodel.writebehind import DEFAULT_INTERVAL, DEFAULT_SIZE, Update, WriteBehind
from mrss.world.geometry import Geometry, GeometryType, geometry_from_text
from mrss.world.objects import Change, Position, WorldObject, merge

log = logging.getLogger("mrss.worldmodel.postgis")
T = TypeVar("T")
SCHEMA_VERSION = 1
_MIGRATION_LOCK = 0x6D7273735F776D  # pg_advisory_xact_lock key of schema changes
_MIGRATIONS = {
    1: [
        "CREATE EXTENSION IF NOT EXISTS postgis",
        """CREATE TABLE IF NOT EXISTS wm_objects (
            id text PRIMARY KEY, kind text NOT NULL,
            lat double precision, lon double precision, alt double precision,
            geojson text, geom geometry(Geometry, 4326),
            attributes jsonb NOT NULL, version integer NOT NULL,
            updated double precision NOT NULL)""",
        "CREATE INDEX IF NOT EXISTS wm_objects_kind ON wm_objects (kind)",
        "CREATE INDEX IF NOT EXISTS wm_objects_geom ON wm_objects USING gist (geom)",
        "CREATE INDEX IF NOT EXISTS wm_objects_geog ON wm_objects "
        "USING gist ((geom::geography))",
    ],
}
_COLUMNS = "id, kind, lat, lon, alt, attributes, version, updated, geojson"
_KIND = "(%(kind)s::text IS NULL OR kind = %(kind)s::text)"
_QUERY = "ST_SetSRID(ST_Force2D(ST_GeomFromGeoJSON(%(q)s::text)), 4326)"
#: A query line longer than this (degrees) is asked about in pieces, one index scan each:
#: the box of a long diagonal would otherwise hold most of the world.
PIECE_DEG = 0.01
MAX_PIECES = 64


def safe_url(url: str) -> str:
    """The URL without its password, for messages."""
    try:
        parts = urlsplit(url)
        host = parts.hostname or "localhost"
        port = f":{parts.port}" if parts.port else ""
    except ValueError:
        return "postgresql://?"
    user = f"{parts.username}@" if parts.username else ""
    return f"{parts.scheme}://{user}{host}{port}{parts.path}"


class PostgisWorldStore:
    """World model objects in PostGIS at `url` (a libpq URL, postgresql://...)."""

    def __init__(self, url: str, *, connect_timeout: float = 3.0, request_timeout: float = 10.0,
                 backoff_initial: float = 0.1, backoff_max: float = 5.0,
                 batch_size: int = DEFAULT_SIZE, batch_interval: float = DEFAULT_INTERVAL
                 ) -> None:
        self.url = url
        self.where = safe_url(url)
        self.connect_timeout = connect_timeout
        self.request_timeout = request_timeout
        self._watchdog = Watchdog(request_timeout)
        self._backoff_initial, self._backoff_max = backoff_initial, backoff_max
        self._delay = backoff_initial
        self._next_attempt = 0.0
        self._lock = threading.Lock()
        self._conn: psycopg.Connection[Any] | None = None
        self.connects = 0
        self.failures = 0
        with self._lock:
            self._connection()
        #: telemetry waiting to be committed together (`upsert_deferred`)
        self.telemetry = WriteBehind(self._get_committed, self._commit_batch, size=batch_size,
                                     interval=batch_interval)

    # --- connection ---------------------------------------------------------------

    def _connection(self) -> psycopg.Connection[Any]:
        if self._conn is not None and not self._conn.closed:
            return self._conn
        now = time.monotonic()
        if now < self._next_attempt:
            raise WorldStoreUnavailable(
                f"world model database {self.where} is down; next attempt in "
                f"{self._next_attempt - now:.1f} s")
        try:
            conn = psycopg.connect(
                self.url, autocommit=True, connect_timeout=max(1, round(self.connect_timeout)),
                keepalives=1, keepalives_idle=5, keepalives_interval=2, keepalives_count=3,
                tcp_user_timeout=10_000, application_name="mrss-worldmodel")
            _migrate(conn)
        except psycopg.Error as exc:
            self._next_attempt = time.monotonic() + self._delay
            self._delay = min(self._delay * 2, self._backoff_max)
            raise WorldStoreUnavailable(
                f"cannot reach the world model database {self.where}: "
                f"{str(exc).strip() or type(exc).__name__}") from None
        self._delay = self._backoff_initial
        self._next_attempt = 0.0
        self._conn = conn
        self.connects += 1
        if self.connects > 1:
            log.warning("world model database %s reconnected", self.where)
        return conn

    def _run(self, work: Callable[[psycopg.Connection[Any]], T], *, flush: bool = True) -> T:
        """`work` on the connection, after the pending telemetry is committed (`flush`)."""
        if flush:
            self.telemetry.flush()
        with self._lock:
            conn = self._connection()
            watchdog = self._watchdog
            watchdog.arm(conn)
            try:
                return work(conn)
            except (psycopg.OperationalError, psycopg.InterfaceError) as exc:
                self.failures += 1
                self._drop()
                if watchdog.fired:
                    raise WorldStoreUnavailable(
                        f"world model database {self.where} did not answer within "
                        f"{self.request_timeout:g} s") from None
                raise WorldStoreUnavailable(
                    f"world model database {self.where} failed: "
                    f"{str(exc).strip() or type(exc).__name__}") from None
            finally:
                watchdog.disarm()

    def _drop(self) -> None:
        conn, self._conn = self._conn, None
        if conn is not None:
            try:
                conn.close()
            except psycopg.Error:
                pass

    def close(self) -> None:
        """Commit the pending telemetry, close the connection."""
        self.telemetry.close()
        with self._lock:
            self._drop()
            self._next_attempt = float("inf")
            self._watchdog.close()

    # --- the store ----------------------------------------------------------------

    def upsert(self, obj: WorldObject, *, replace_attributes: bool = False) -> Change:
        """Insert `obj`, or update the object with its id; returns once committed."""
        def work(conn: psycopg.Connection[Any]) -> Change:
            with conn.transaction():
                conn.execute("SELECT pg_advisory_xact_lock(hashtextextended(%s, 0))",
                             (obj.id,))
                change = merge(obj, _get(conn, obj.id), replace_attributes=replace_attributes)
                if change.op != "unchanged":
                    _write(conn, change.obj)
            return change
        return self._run(work)

    def upsert_deferred(self, obj: WorldObject, *, replace_attributes: bool = False
                        ) -> Change:
        """Queue `obj` (telemetry) to be committed with others in one transaction; its
        Change as this process sees it. Not durable on return (`WriteBehind`)."""
        return self.telemetry.stage(obj, replace_attributes=replace_attributes)

    def _commit_batch(self, updates: list[Update]) -> None:
        """Commit queued updates in one transaction, each object's in order."""
        def work(conn: psycopg.Connection[Any]) -> None:
            ids = sorted({obj.id for obj, _ in updates})
            with conn.transaction(), conn.cursor() as cur:
                cur.executemany("SELECT pg_advisory_xact_lock(hashtextextended(%s, 0))",
                                [(i,) for i in ids])
                rows = conn.execute(f"SELECT {_COLUMNS} FROM wm_objects WHERE id = ANY(%s)",
                                    (ids,)).fetchall()
                now: dict[str, WorldObject | None] = {i: None for i in ids}
                now.update({r[0]: _row_object(r) for r in rows})
                dirty: dict[str, WorldObject] = {}
                for obj, replace in updates:
                    change = merge(obj, now[obj.id], replace_attributes=replace)
                    if change.op != "unchanged":
                        now[obj.id] = dirty[obj.id] = change.obj
                if dirty:
                    cur.executemany(_WRITE, [_write_params(o) for o in dirty.values()])
        self._run(work, flush=False)

    def get(self, object_id: str) -> WorldObject | None:
        """The object with this id, or None."""
        return self._run(lambda conn: _get(conn, object_id))

    def _get_committed(self, object_id: str) -> WorldObject | None:
        return self._run(lambda conn: _get(conn, object_id), flush=False)

    def delete(self, object_id: str) -> bool:
        """Remove an object; False when there was none."""
        return self._run(lambda conn: conn.execute(
            "DELETE FROM wm_objects WHERE id = %s", (object_id,)).rowcount > 0)

    def objects(self, kind: str | None = None) -> list[WorldObject]:
        """Every object, or those of one kind, ordered by id."""
        return self._select(f"SELECT {_COLUMNS} FROM wm_objects WHERE {_KIND} ORDER BY id",
                            {"kind": kind})

    def near(self, position: Position, radius_m: float,
             kind: str | None = None) -> list[tuple[WorldObject, float]]:
        """Objects within `radius_m` metres of `position`, nearest first, with distances."""
        return self.within_distance(position.geometry(), radius_m, kind)

    def intersecting(self, geometry: Geometry, kind: str | None = None) -> list[WorldObject]:
        """Objects whose shape shares a point with `geometry`, ordered by id."""
        pieces = line_pieces(geometry)
        if pieces is not None:
            return self._select(
                f"SELECT {_COLUMNS} FROM wm_objects WHERE {_KIND} AND id IN ("
                "SELECT o.id FROM wm_objects o, unnest(%(pieces)s::text[]) AS piece(t) "
                "WHERE ST_Intersects(o.geom, ST_SetSRID(ST_GeomFromGeoJSON(piece.t), 4326))"
                ") ORDER BY id", {"kind": kind, "pieces": pieces})
        return self._select(
            f"SELECT {_COLUMNS} FROM wm_objects WHERE {_KIND} "
            f"AND ST_Intersects(geom, {_QUERY}) ORDER BY id",
            {"kind": kind, "q": geometry.to_text()})

    def within(self, geometry: Geometry, kind: str | None = None) -> list[WorldObject]:
        """Objects whose shape lies inside `geometry`, ordered by id."""
        return self._select(
            f"SELECT {_COLUMNS} FROM wm_objects WHERE {_KIND} "
            f"AND ST_Within(geom, {_QUERY}) ORDER BY id",
            {"kind": kind, "q": geometry.to_text()})

    def within_distance(self, geometry: Geometry, distance_m: float,
                        kind: str | None = None) -> list[tuple[WorldObject, float]]:
        """Objects within `distance_m` metres of `geometry`, nearest first, with distances."""
        sql = (f"SELECT {_COLUMNS}, ST_Distance(geom::geography, q.g, false) AS d "
               f"FROM wm_objects, (SELECT {_QUERY}::geography AS g) AS q "
               f"WHERE {_KIND} AND ST_DWithin(geom::geography, q.g, %(d)s::float8, false) "
               "ORDER BY d, id")
        params = {"kind": kind, "q": geometry.to_text(), "d": float(distance_m)}
        rows = self._run(lambda conn: conn.execute(sql, params).fetchall())
        return [(_row_object(r[:9]), float(r[9])) for r in rows]

    def _select(self, sql: str, params: dict[str, Any]) -> list[WorldObject]:
        rows = self._run(lambda conn: conn.execute(sql, params).fetchall())
        return [_row_object(r) for r in rows]

    def schema_version(self) -> int:
        """The schema version recorded in the database."""
        row = self._run(lambda conn: conn.execute(
            "SELECT max(version) FROM wm_schema_version").fetchone())
        return int(row[0]) if row and row[0] is not None else 0


def line_pieces(geometry: Geometry) -> list[str] | None:
    """A LineString longer than PIECE_DEG as consecutive straight pieces (GeoJSON), the
    same points of the lon/lat plane (each piece ends where the next begins; the line's
    own vertices are kept exactly); None for a shorter line or another shape."""
    if geometry.type is not GeometryType.LINESTRING:
        return None
    points = [tuple(c[:2]) for c in geometry.coordinates]
    segments = list(zip(points, points[1:], strict=False))
    lengths = [math.dist(a, b) for a, b in segments]
    total = sum(lengths)
    if total <= PIECE_DEG:
        return None
    step = max(PIECE_DEG, total / MAX_PIECES)
    pieces = []
    for (a, b), length in zip(segments, lengths, strict=True):
        n = max(1, math.ceil(length / step))
        ends = [a, *[(a[0] + (b[0] - a[0]) * k / n, a[1] + (b[1] - a[1]) * k / n)
                     for k in range(1, n)], b]
        pieces += [json.dumps({"type": "LineString", "coordinates": [list(p), list(q)]})
                   for p, q in zip(ends, ends[1:], strict=False)]
    return pieces


def _migrate(conn: psycopg.Connection[Any]) -> None:
    """Create or bring the schema up to SCHEMA_VERSION (idempotent, concurrent-safe)."""
    with conn.transaction():
        conn.execute("SELECT pg_advisory_xact_lock(%s)", (_MIGRATION_LOCK,))
        conn.execute("CREATE TABLE IF NOT EXISTS wm_schema_version ("
                     "version integer PRIMARY KEY, applied timestamptz NOT NULL DEFAULT now())")
        row = conn.execute("SELECT coalesce(max(version), 0) FROM wm_schema_version").fetchone()
        current = int(row[0]) if row else 0
        for step in range(current + 1, SCHEMA_VERSION + 1):
            for statement in _MIGRATIONS[step]:
                conn.execute(statement)
            conn.execute("INSERT INTO wm_schema_version (version) VALUES (%s)", (step,))
            log.info("world model schema migrated to version %d", step)


def _get(conn: psycopg.Connection[Any], object_id: str) -> WorldObject | None:
    row = conn.execute(f"SELECT {_COLUMNS} FROM wm_objects WHERE id = %s",
                       (object_id,)).fetchone()
    return None if row is None else _row_object(row)


_WRITE = (
    f"INSERT INTO wm_objects ({_COLUMNS}, geom) VALUES (%(id)s, %(kind)s, %(lat)s, "
    "%(lon)s, %(alt)s, %(attributes)s, %(version)s, %(updated)s, %(geojson)s, "
    "CASE WHEN %(shape)s::text IS NULL THEN NULL ELSE "
    "ST_SetSRID(ST_Force2D(ST_GeomFromGeoJSON(%(shape)s::text)), 4326) END) "
    "ON CONFLICT (id) DO UPDATE SET kind = EXCLUDED.kind, lat = EXCLUDED.lat, "
    "lon = EXCLUDED.lon, alt = EXCLUDED.alt, attributes = EXCLUDED.attributes, "
    "version = EXCLUDED.version, updated = EXCLUDED.updated, "
    "geojson = EXCLUDED.geojson, geom = EXCLUDED.geom")


def _write_params(new: WorldObject) -> dict[str, Any]:
    pos, shape = new.position, new.shape_geometry()
    return {"id": new.id, "kind": new.kind, "lat": pos.lat if pos else None,
            "lon": pos.lon if pos else None, "alt": pos.alt if pos else None,
            "attributes": Jsonb(new.attributes), "version": new.version,
            "updated": new.updated,
            "geojson": None if new.geometry is None else new.geometry.to_text(),
            "shape": None if shape is None else shape.to_text()}


def _write(conn: psycopg.Connection[Any], new: WorldObject) -> None:
    conn.execute(_WRITE, _write_params(new))


def _row_object(row: Any) -> WorldObject:
    oid, kind, lat, lon, alt, attributes, version, updated, geojson = row
    position = None if lat is None else Position(lat, lon, alt or 0.0)
    return WorldObject(oid, kind, position, dict(attributes), version, updated,
                       None if geojson is None else geometry_from_text(geojson))
