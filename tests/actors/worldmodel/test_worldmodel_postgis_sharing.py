"""Several world models on one PostGIS database: merges from all of them are kept.

Uses the private server of tests/actors/worldmodel/pgcluster.py (skipped without PostgreSQL 15 +
postgresql-15-postgis-3; failing instead when MRSS_REQUIRE_POSTGIS=1).
"""

from __future__ import annotations

import threading

from mrss.actors.worldmodel.postgis import PostgisWorldStore
from mrss.actors.worldmodel.store import Position, WorldObject


def test_stores_on_one_database_merge_each_others_writes(postgis_url: str) -> None:
    stores = [PostgisWorldStore(postgis_url) for _ in range(3)]
    try:
        stores[0].upsert(WorldObject("shared", "zone", Position(43.6, 1.44)))

        def writer(n: int) -> None:
            for i in range(15):
                stores[n].upsert(WorldObject("shared", "zone", None, {f"s{n}_{i}": i}))
        threads = [threading.Thread(target=writer, args=(n,)) for n in range(3)]
        for t in threads:
            t.start()
        for t in threads:
            t.join()
        seen = [store.get("shared") for store in stores]
        assert all(s is not None and len(s.attributes) == 45 and s.version == 46
                   for s in seen)
        assert stores[2].near(Position(43.6, 1.44), 1)[0][0].id == "shared"
    finally:
        for store in stores:
            store.close()
