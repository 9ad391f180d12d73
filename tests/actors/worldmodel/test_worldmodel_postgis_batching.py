"""PostGIS telemetry batching (`upsert_deferred`, `mrss.actors.worldmodel.writebehind`).

Uses the private server of tests/actors/worldmodel/pgcluster.py (skipped without PostgreSQL 15 +
postgresql-15-postgis-3; failing instead when MRSS_REQUIRE_POSTGIS=1). A second store
(its own connection, as another process would have) shows what is committed.
"""

from __future__ import annotations

from collections.abc import Iterator

import pytest

from mrss.actors.worldmodel.model import WorldModel
from mrss.actors.worldmodel.postgis import PostgisWorldStore
from mrss.actors.worldmodel.store import Position, WorldObject
from mrss.testing import wait_until

HOUR = 3600.0  # an interval that never fires within a test


@pytest.fixture
def other(postgis_url: str) -> Iterator[PostgisWorldStore]:
    store = PostgisWorldStore(postgis_url)
    yield store
    store.close()


def telemetry(robot: str, n: int) -> WorldObject:
    return WorldObject(robot, "robot", Position(43.0 + n * 1e-4, 1.0), {"n": n, f"k{n}": n})


def committed_n(store: PostgisWorldStore, robot: str) -> int | None:
    obj = store._get_committed(robot)  # what the database holds, without flushing
    return None if obj is None else int(obj.attributes["n"])


def test_updates_wait_for_their_batch_size_and_commit_together_in_order(
        postgis_url: str, other: PostgisWorldStore) -> None:
    store = PostgisWorldStore(postgis_url, batch_size=10, batch_interval=HOUR)
    try:
        changes = [store.upsert_deferred(telemetry(f"bt-{i % 2}", i)) for i in range(25)]
        assert [c.op for c in changes[:2]] == ["insert", "insert"]
        assert all(c.op == "update" for c in changes[2:])
        assert store.telemetry.batches == 2 and store.telemetry.pending == 5
        # committed: the first 20 updates, two batches; each robot's in order
        assert committed_n(other, "bt-0") == 18 and committed_n(other, "bt-1") == 19
        stored = other.get("bt-1")
        assert stored is not None and stored.version == 10  # 10 updates applied, in turn
        assert all(f"k{n}" in stored.attributes for n in range(1, 20, 2))
    finally:
        store.close()  # commits the rest
    assert committed_n(other, "bt-0") == 24 and committed_n(other, "bt-1") == 23


def test_a_read_commits_the_pending_updates_first(postgis_url: str,
                                                  other: PostgisWorldStore) -> None:
    store = PostgisWorldStore(postgis_url, batch_size=1000, batch_interval=HOUR)
    try:
        store.upsert_deferred(telemetry("rd-1", 1))
        store.upsert_deferred(telemetry("rd-1", 2))
        assert store.telemetry.pending == 2
        seen = store.get("rd-1")  # its own pending writes: flushed first
        assert seen is not None and seen.attributes["n"] == 2 and seen.version == 2
        assert store.telemetry.pending == 0 and committed_n(other, "rd-1") == 2
        store.upsert_deferred(telemetry("rd-2", 7))
        assert [o.id for o, _ in store.near(Position(43.0007, 1.0), 5)] == ["rd-2"]
        store.upsert_deferred(telemetry("rd-2", 8))
        store.upsert(WorldObject("rd-2", "robot", None, {"mode": "manual"}))  # acknowledged
        final = other.get("rd-2")
        assert final is not None and final.attributes["n"] == 8
        assert final.attributes["mode"] == "manual" and final.version == 3
    finally:
        store.close()


def test_the_interval_commits_a_batch_that_does_not_fill(postgis_url: str,
                                                         other: PostgisWorldStore) -> None:
    store = PostgisWorldStore(postgis_url, batch_size=1000, batch_interval=0.05)
    try:
        for n in range(3):
            store.upsert_deferred(telemetry("iv-1", n))
        wait_until(lambda: committed_n(other, "iv-1") == 2, 30,
                   message="the batch committed by the interval")
        assert store.telemetry.batches == 1 and store.telemetry.committed == 3
    finally:
        store.close()


def test_a_batch_merges_onto_what_another_process_wrote_meanwhile(
        postgis_url: str, other: PostgisWorldStore) -> None:
    store = PostgisWorldStore(postgis_url, batch_size=1000, batch_interval=HOUR)
    try:
        store.upsert_deferred(WorldObject("mg-1", "robot", Position(43.1, 1.1), {"a": 1}))
        other.upsert(WorldObject("mg-1", "robot", None, {"b": 2}))  # another process
        store.telemetry.flush()
        final = other.get("mg-1")
        assert final is not None and final.attributes == {"a": 1, "b": 2}
        assert final.position == Position(43.1, 1.1)
    finally:
        store.close()


def test_the_world_model_batches_the_writes_nobody_waits_for(postgis_url: str,
                                                             other: PostgisWorldStore) -> None:
    store = PostgisWorldStore(postgis_url, batch_size=1000, batch_interval=HOUR)
    world = WorldModel(store)
    try:
        entry = {"id": "wm-1", "kind": "robot", "position": {"lat": 43.2, "lon": 1.2}}
        assert world.call("wm.upsert", [entry], answer=False) == {"op": "insert"}
        assert store.telemetry.pending == 1 and other.get("wm-1") is None
        world.call("wm.upsert_many", [[{**entry, "attributes": {"y": 2}}]], answer=False)
        assert store.telemetry.pending == 2 and other.get("wm-1") is None
        answered = world.call("wm.upsert", [{**entry, "attributes": {"x": 1}}])
        assert answered["op"] == "update" and store.telemetry.pending == 0
        stored = other.get("wm-1")
        assert stored is not None and stored.attributes == {"x": 1, "y": 2}
    finally:
        store.close()
