"""`mrss bench worldmodel`: world model store operations on each backend.

Always the embedded SQLite store (in memory); PostGIS too when MRSS_BENCH_POSTGIS_URL
names a scratch database (postgresql://...): the benchmark's objects (ids `bench-*`)
are deleted afterwards. Objects are points and 550 m squares scattered over a
40 x 55 km area; queries are around its middle.
"""

from __future__ import annotations

import os
import random
import time
from collections.abc import Callable
from typing import Any

from mrss.bench.report import BenchReport
from mrss.edge.worldmodel_store import (
    Geometry,
    Position,
    SqliteWorldStore,
    WorldObject,
    WorldStore,
)

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


def _percentile(samples: list[float], q: float) -> float:
    ordered = sorted(samples)
    return ordered[min(len(ordered) - 1, int(q * len(ordered)))] * 1e3


def _timed(report: BenchReport, backend: str, what: str, calls: list[Callable[[], object]]
           ) -> None:
    samples = []
    for call in calls:
        start = time.perf_counter()
        call()
        samples.append(time.perf_counter() - start)
    report.add_row(backend, what, len(samples), round(_percentile(samples, 0.5), 3),
                   round(_percentile(samples, 0.95), 3))


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
    report = BenchReport("worldmodel", ["backend", "operation", "n", "p50 ms", "p95 ms"],
                         quick=quick)
    sqlite = SqliteWorldStore()
    try:
        _measure(report, "sqlite (memory)", sqlite, n, queries)
    finally:
        sqlite.close()
    url = os.environ.get(URL_ENV)
    if url:
        from mrss.edge.worldmodel_postgis import PostgisWorldStore, safe_url
        store = PostgisWorldStore(url)
        try:
            _measure(report, "postgis", store, n, queries)
            for i in range(n):
                store.delete(f"bench-{i}")
        finally:
            store.close()
        report.notes.append(f"PostGIS at {safe_url(url)}")
    else:
        report.notes.append(f"PostGIS not measured: set {URL_ENV}=postgresql://... "
                            "(a scratch database)")
    report.notes.append(f"{n} objects (half points, half 550 m squares) over 40 x 55 km")
    return report
