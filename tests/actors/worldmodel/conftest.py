"""Fixtures for the world model's tests: a private PostGIS server, a store of each backend."""

from __future__ import annotations

import uuid
from collections.abc import Iterator
from pathlib import Path

import pytest

from mrss.actors.worldmodel.store import SqliteWorldStore, WorldStore
from tests.actors.worldmodel.pgcluster import PgCluster, started_cluster
from tests.actors.worldmodel.stores import StoreFactory

# --- world model backends -------------------------------------------------------------


@pytest.fixture(scope="session")
def postgis_cluster() -> Iterator[PgCluster]:
    """One private PostgreSQL + PostGIS server for the session's tests (see pgcluster.py)."""
    cluster = started_cluster()
    try:
        yield cluster
    finally:
        cluster.stop()


@pytest.fixture
def postgis_url(postgis_cluster: PgCluster) -> str:
    """A fresh, empty database of the session's PostGIS server."""
    return postgis_cluster.create_database("wm_" + uuid.uuid4().hex[:16])


@pytest.fixture(params=["sqlite", "postgis"])
def open_store(request: pytest.FixtureRequest, tmp_path: Path) -> Iterator[StoreFactory]:
    """Opens the world store of one backend; every call opens the same database again."""
    if request.param == "sqlite":
        def factory() -> WorldStore:
            return SqliteWorldStore(tmp_path / "wm.sqlite")
    else:
        url = request.getfixturevalue("postgis_url")

        def factory() -> WorldStore:
            from mrss.actors.worldmodel.postgis import PostgisWorldStore
            return PostgisWorldStore(url)
    opened: list[WorldStore] = []

    def tracked() -> WorldStore:
        opened.append(factory())
        return opened[-1]
    try:
        yield tracked
    finally:
        for store in opened:
            store.close()
