"""The world model component chooses its store from `[worldmodel] url`: PostGIS or SQLite.

The PostGIS run uses the private server of tests/actors/worldmodel/pgcluster.py (skipped without
PostgreSQL 15 + postgresql-15-postgis-3; failing instead when MRSS_REQUIRE_POSTGIS=1).
"""

from __future__ import annotations

import shutil
import tempfile
from pathlib import Path
from typing import Any

import pytest

from mrss.actors.worldmodel.postgis import PostgisWorldStore
from mrss.actors.worldmodel.service import WorldModelComponent, open_store
from mrss.actors.worldmodel.sqlite import SqliteWorldStore
from mrss.bus import BusEndpoints, ProxyThread
from mrss.errors import ConfigError
from mrss.runtime.busport import ZmqBusPort
from mrss.runtime.datalayer_client import DataLayerUnavailable
from mrss.testing import wait_until
from mrss.world.access import BusWorldModel, WorldModelClient
from tests.edge.test_edge_bus import context

ZONE = {"type": "Polygon", "coordinates": [[[1.0, 43.0], [1.1, 43.0], [1.1, 43.1],
                                            [1.0, 43.1], [1.0, 43.0]]]}


def test_component_with_url_keeps_the_world_in_postgis(postgis_url: str) -> None:
    run_dir = Path(tempfile.mkdtemp(prefix="mrss-wm-pg-"))
    endpoints = BusEndpoints.ipc(run_dir)
    component = WorldModelComponent()
    contexts = []
    try:
        with ProxyThread(endpoints):
            ctx = context("worldmodel", run_dir, endpoints, {"url": postgis_url})
            contexts.append(ctx)
            component.start(ctx)
            assert component.world is not None
            assert isinstance(component.world.store, PostgisWorldStore)
            caller = context("reasoner", run_dir, endpoints)
            contexts.append(caller)
            port = ZmqBusPort(endpoints, caller.publisher, "reasoner")
            bus = BusWorldModel(port, timeout=0.5)
            try:
                seeded = wait_until(lambda: _answer(bus, "lake"), timeout=15,
                                    message="world model answering on the bus")
                assert seeded["kind"] == "water_source"
                bus.client.default_timeout = 30.0  # short only while polling for the start
                assert bus.upsert({"id": "z1", "kind": "zone", "geometry": ZONE})["op"] == \
                    "insert"
                assert [o["id"] for o in bus.intersecting(ZONE)] == ["z1"]
                assert [o["id"] for o in bus.within(ZONE, "zone")] == ["z1"]
                near = bus.within_distance({"type": "Point", "coordinates": [1.2, 43.05]},
                                           10_000, "zone")
                assert [o["id"] for o in near] == ["z1"]
                assert near[0]["distance_m"] == pytest.approx(8_130, rel=0.01)
            finally:
                bus.close()
                port.close()
            http = WorldModelClient(run_dir=run_dir)
            zone = http.get("z1")
            assert zone is not None and zone["geometry"] == ZONE
            component.stop()
            # The objects are in the database, not in the run folder.
            assert not (run_dir / "worldmodel.sqlite").exists()
            direct = PostgisWorldStore(postgis_url)
            assert {o.id for o in direct.objects()} >= {"lake", "z1"}
            direct.close()
    finally:
        for each in contexts:
            each.publisher.close()
        shutil.rmtree(run_dir, ignore_errors=True)


def _answer(bus: BusWorldModel, object_id: str) -> dict[str, Any] | None:
    try:
        return bus.get(object_id)
    except DataLayerUnavailable:  # not subscribed yet: timed out
        return None


def test_store_choice_from_the_configuration(tmp_path: Path) -> None:
    store = open_store(tmp_path, {})
    assert isinstance(store, SqliteWorldStore)
    store.close()
    assert (tmp_path / "worldmodel.sqlite").exists()
    for url in ("mysql://db:3306/world", "sqlite:///world.db", 5432):
        with pytest.raises(ConfigError, match="did you mean postgresql://") as caught:
            open_store(tmp_path, {"url": url})
        assert "worldmodel.url" in str(caught.value)
