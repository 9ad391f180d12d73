"""The PostGIS world model when its server crashes: errors, reconnection, no lost writes.

A private PostgreSQL server (tests/actors/worldmodel/pgcluster.py) is killed with SIGKILL while a
writer thread upserts, then started again. Skipped without PostgreSQL 15 +
postgresql-15-postgis-3; fails instead when MRSS_REQUIRE_POSTGIS=1 (CI).
"""

from __future__ import annotations

import threading

import pytest

from mrss.actors.worldmodel.model import WorldModel
from mrss.actors.worldmodel.postgis import PostgisWorldStore
from mrss.actors.worldmodel.store import Position, WorldObject, WorldStoreUnavailable
from mrss.messages import DataRequest
from mrss.testing import wait_until
from tests.actors.worldmodel.pgcluster import started_cluster


@pytest.mark.slow
def test_server_crash_errors_in_flight_reconnects_and_loses_no_acknowledged_write() -> None:
    cluster = started_cluster()
    try:
        url = cluster.create_database("wm")
        store = PostgisWorldStore(url, backoff_max=0.5)
        world = WorldModel(store)
        acknowledged: list[int] = []
        errors: list[str] = []
        stop = threading.Event()

        def writer() -> None:
            i = 0
            while not stop.is_set():
                try:
                    world.upsert(WorldObject(f"o{i}", "robot", Position(43.6, 1.44 + i * 1e-5),
                                             {"i": i}))
                    acknowledged.append(i)
                except WorldStoreUnavailable as exc:
                    errors.append(str(exc))
                    stop.wait(0.01)  # pace the retries of this test's writer
                i += 1

        thread = threading.Thread(target=writer, name="wm-writer", daemon=True)
        thread.start()
        wait_until(lambda: len(acknowledged) >= 20, timeout=60, message="writes before")
        cluster.kill()
        wait_until(lambda: errors, timeout=30, message="an error for a write in flight")
        # While the server is down every request answers at once, with an error.
        with pytest.raises(WorldStoreUnavailable, match="world model database"):
            store.get("o0")
        reply = world.handle(DataRequest(request_id="r1", function="wm.get", args=["o0"]))
        assert not reply.ok and "world model database" in str(reply.error)
        with pytest.raises(WorldStoreUnavailable, match="cannot reach"):
            PostgisWorldStore(url)
        before_restart = len(acknowledged)
        cluster.restart_after_crash()
        wait_until(lambda: len(acknowledged) >= before_restart + 20, timeout=60,
                   message="writes after the restart")
        stop.set()
        thread.join(timeout=30)
        assert not thread.is_alive()
        assert store.connects >= 2 and store.failures >= 1
        assert any("next attempt in" in e for e in errors), "no backoff between attempts"
        check = PostgisWorldStore(url)
        stored = {o.id: o.attributes["i"] for o in check.objects("robot")}
        check.close()
        lost = [i for i in acknowledged if stored.get(f"o{i}") != i]
        assert lost == [], f"acknowledged writes lost in the crash: {lost[:10]}"
        store.close()
    finally:
        cluster.stop()


@pytest.mark.slow
def test_a_frozen_server_times_requests_out_instead_of_hanging() -> None:
    cluster = started_cluster()
    try:
        url = cluster.create_database("wm")
        store = PostgisWorldStore(url, connect_timeout=2.0, request_timeout=1.0)
        store.upsert(WorldObject("a", "robot", Position(43.6, 1.44)))
        cluster.freeze()
        try:
            with pytest.raises(WorldStoreUnavailable, match="did not answer within 1 s"):
                store.get("a")
            with pytest.raises(WorldStoreUnavailable, match="cannot reach|next attempt"):
                store.get("a")  # reconnecting to a frozen server times out too
        finally:
            cluster.thaw()
        found = wait_until(lambda: _get_or_none(store, "a"), timeout=60,
                           message="the store back after the server thawed")
        assert found.id == "a" and store.connects == 2
        store.close()
    finally:
        cluster.stop()


def _get_or_none(store: PostgisWorldStore, object_id: str) -> WorldObject | None:
    try:
        return store.get(object_id)
    except WorldStoreUnavailable:
        return None
