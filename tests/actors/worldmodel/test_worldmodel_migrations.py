"""Schema creation and migration of the world model backends: idempotent, concurrent-safe.

The PostGIS tests use the private server of tests/actors/worldmodel/pgcluster.py (skipped without
PostgreSQL 15 + postgresql-15-postgis-3, failing instead when MRSS_REQUIRE_POSTGIS=1).
"""

from __future__ import annotations

import sqlite3
import threading
from pathlib import Path

import psycopg

from mrss.actors.worldmodel.postgis import SCHEMA_VERSION, PostgisWorldStore
from mrss.actors.worldmodel.sqlite import SCHEMA_VERSION as SQLITE_VERSION
from mrss.actors.worldmodel.store import Position, SqliteWorldStore, WorldStore


def test_a_first_release_sqlite_file_is_migrated_in_place(tmp_path: Path) -> None:
    path = tmp_path / "old.sqlite"
    db = sqlite3.connect(path)
    db.executescript("""
        CREATE TABLE objects (id TEXT PRIMARY KEY, kind TEXT NOT NULL, lat REAL, lon REAL,
            alt REAL, attributes TEXT NOT NULL, version INTEGER NOT NULL,
            updated REAL NOT NULL);
        CREATE INDEX objects_kind ON objects(kind);
        INSERT INTO objects VALUES ('lake', 'water_source', 43.6, 1.44, 0, '{"v": 1}', 3, 1.0);
    """)
    db.commit()
    db.close()
    for _ in range(2):  # the second open finds nothing to do
        store = SqliteWorldStore(path)
        lake = store.get("lake")
        assert lake is not None and lake.version == 3 and lake.attributes == {"v": 1}
        assert [o.id for o, _ in store.near(Position(43.6, 1.44), 10)] == ["lake"]
        store.close()
    (version,) = sqlite3.connect(path).execute("PRAGMA user_version").fetchone()
    assert version == SQLITE_VERSION == 3


def test_postgis_schema_is_created_once_by_concurrent_starts(postgis_url: str) -> None:
    stores: list[WorldStore] = []
    errors: list[BaseException] = []

    def start() -> None:
        try:
            stores.append(PostgisWorldStore(postgis_url))
        except BaseException as exc:  # noqa: BLE001 (reported below)
            errors.append(exc)
    threads = [threading.Thread(target=start) for _ in range(3)]
    for t in threads:
        t.start()
    for t in threads:
        t.join()
    assert errors == [] and len(stores) == 3
    for store in stores:
        store.close()
    again = PostgisWorldStore(postgis_url)  # idempotent on an up-to-date database
    assert again.schema_version() == SCHEMA_VERSION == 1
    again.close()
    with psycopg.connect(postgis_url) as conn:
        assert conn.execute("SELECT count(*) FROM wm_schema_version").fetchone() == (1,)
        indexes = {r[0] for r in conn.execute(
            "SELECT indexdef FROM pg_indexes WHERE tablename = 'wm_objects'")}
        assert any("USING gist (geom)" in i for i in indexes)
        assert any("USING gist (((geom)::geography))" in i for i in indexes)
        srid = conn.execute("SELECT Find_SRID('public', 'wm_objects', 'geom')").fetchone()
        assert srid == (4326,)
