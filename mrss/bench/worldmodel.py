"""`mrss bench worldmodel`: world model store operations on each backend.

Always the embedded SQLite store (in memory); PostGIS too when MRSS_BENCH_POSTGIS_URL
names a scratch database (postgresql://...): the benchmark's objects (ids `bench-*`,
and `habitat`, `rover1`) are deleted afterwards. Objects are points and 550 m squares
scattered over a 40 x 55 km area; queries are around its middle. Then, on a fresh
world, the AMADEE-24 legality check (10,000 zones, 1,000 objects) and telemetry writes
(5 Hz x 100 robots), with the issue's targets (`worldmodel_legality`); on PostGIS also
the telemetry batched vs one transaction per update (`worldmodel_batching`).
"""

from __future__ import annotations

import os
import random
import time
from collections.abc import Callable
from typing import Any

from mrss.actors.worldmodel.store import (
    Geometry,
    Position,
    SqliteWorldStore,
    WorldObject,
    WorldStore,
)
from mrss.bench.report import BenchReport
from mrss.bench.worldmodel_legality import add_timed_row, legality_and_telemetry

URL_ENV = "MRSS_BENCH_POSTGIS_URL"


def _square(lon: float, lat: float, size: float) -> dict[str, Any]:
    ring = [[lon, lat], [lon + size, lat], [lon + size, lat + size], [lon, lat + size],
            [lon, lat]]
    return {"type": "Polygon", "coordinates": [ring]}


def _objects(n: int) -> list[WorldObject]:
    rnd = random.Random(7)
    out = []
    for i in range(n):
        lon, lat = 1.0 + rnd.random() * 0.5, 43.0 + rnd.random() * 0.5
        if i % 2:
            out.append(WorldObject(f"bench-{i}", "robot", Position(lat, lon), {"i": i}))
        else:
            out.append(WorldObject.from_json({"id": f"bench-{i}", "kind": "zone",
                                              "geometry": _square(lon, lat, 0.005)}))
    return out


def _timed(report: BenchReport, backend: str, what: str, calls: list[Callable[[], object]]
           ) -> None:
    samples = []
    for call in calls:
        start = time.perf_counter()
        call()
        samples.append(time.perf_counter() - start)
    add_timed_row(report, backend, what, samples)


def _upsert(store: WorldStore, obj: WorldObject) -> Callable[[], object]:
    return lambda: store.upsert(obj)


def _measure(report: BenchReport, backend: str, store: WorldStore, n: int, queries: int) -> None:
    objects = _objects(n)
    _timed(report, backend, "upsert (insert)",
           [_upsert(store, o) for o in objects])
    _timed(report, backend, "get", [lambda: store.get("bench-1")] * queries)
    middle = Position(43.25, 1.25)
    area = Geometry.from_json(_square(1.2, 43.2, 0.05))
    _timed(report, backend, "near 2 km", [lambda: store.near(middle, 2000)] * queries)
    _timed(report, backend, "intersecting a 4 km square",
           [lambda: store.intersecting(area)] * queries)
    _timed(report, backend, "within a 4 km square", [lambda: store.within(area)] * queries)
    _timed(report, backend, "within 1 km of a 4 km square",
           [lambda: store.within_distance(area, 1000)] * queries)


def run(quick: bool) -> BenchReport:
    """Measure each backend; `quick` uses small counts."""
    n, queries = (200, 50) if quick else (5000, 500)
    report = BenchReport("worldmodel", ["backend", "operation", "n", "p50 ms", "p95 ms",
                                        "p99 ms", "per s"], quick=quick)
    sqlite = SqliteWorldStore()
    try:
        _measure(report, "sqlite (memory)", sqlite, n, queries)
    finally:
        sqlite.close()
    sqlite = SqliteWorldStore()
    try:
        legality_and_telemetry(report, "sqlite (memory)", sqlite, quick=quick,
                               p99_target_ms=20.0)
    finally:
        sqlite.close()
    url = os.environ.get(URL_ENV)
    if url:
        from mrss.actors.worldmodel.postgis import PostgisWorldStore, safe_url
        from mrss.bench.worldmodel_batching import telemetry_batching
        store = PostgisWorldStore(url)
        try:
            _measure(report, "postgis", store, n, queries)
            for i in range(n):
                store.delete(f"bench-{i}")
            made = legality_and_telemetry(report, "postgis", store, quick=quick,
                                          p99_target_ms=10.0)
            made += telemetry_batching(report, url, quick=quick)
            for object_id in made:
                store.delete(object_id)
        finally:
            store.close()
        report.notes.append(f"PostGIS at {safe_url(url)}")
    else:
        report.notes.append(f"PostGIS not measured: set {URL_ENV}=postgresql://... "
                            "(a scratch database)")
    report.notes.append(f"{n} objects (half points, half 550 m squares) over 40 x 55 km")
    report.notes.append("legality check: legality.judge of projects/amadee on the world "
                        "model in this process (the data layer's bus hop and its stored "
                        "verdict not included); per s = n / the summed durations")
    return report
