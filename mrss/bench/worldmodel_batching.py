"""Rows of `mrss bench worldmodel` for PostGIS telemetry batching: the same telemetry
(TELEMETRY_ROBOTS robots in turns) written one transaction per update (`upsert`, as an
acknowledged write) and batched (`upsert(..., deferred=True)`, a write nobody waits for,
committed `batch_size` per transaction or every `batch_interval`), in the same run.

p50/p95/p99 are the caller's time per update; "per s" is updates over the wall time
including the last batch's commit, and the note gives the ratio.
"""

from __future__ import annotations

import random
import time

from mrss.actors.worldmodel.model import WorldModel
from mrss.actors.worldmodel.postgis import PostgisWorldStore
from mrss.actors.worldmodel.store import Position, WorldObject
from mrss.actors.worldmodel.writebehind import DEFAULT_INTERVAL, DEFAULT_SIZE
from mrss.bench.report import BenchReport
from mrss.bench.worldmodel_legality import TELEMETRY_ROBOTS, percentile_ms


def _updates(writes: int, prefix: str) -> list[WorldObject]:
    rnd = random.Random(9)
    return [WorldObject(f"{prefix}{i % TELEMETRY_ROBOTS}", "robot",
                        Position(43.0 + rnd.uniform(-0.01, 0.01), 1.0 + rnd.uniform(-0.01, 0.01)),
                        {"speed": round(rnd.uniform(0, 1.5), 2), "battery": 100 - i / writes})
            for i in range(writes)]


def _row(report: BenchReport, what: str, samples: list[float], wall: float) -> float:
    rate = len(samples) / wall
    report.add_row("postgis", what, len(samples), round(percentile_ms(samples, 0.5), 3),
                   round(percentile_ms(samples, 0.95), 3),
                   round(percentile_ms(samples, 0.99), 3), round(rate))
    return rate


def telemetry_batching(report: BenchReport, url: str, *, quick: bool) -> list[str]:
    """Both ways on the database at `url`; the ids written (to delete)."""
    writes = 1000 if quick else 10_000
    rates = {}
    for name, deferred in (("one transaction per update", False), ("batched", True)):
        store = PostgisWorldStore(url)
        world = WorldModel(store)
        updates = _updates(writes, f"bench-batch-{int(deferred)}-")
        samples = []
        start = time.perf_counter()
        for obj in updates:
            t0 = time.perf_counter()
            world.upsert(obj, deferred=deferred)
            samples.append(time.perf_counter() - t0)
        store.telemetry.flush()
        wall = time.perf_counter() - start
        batches = store.telemetry.batches
        store.close()
        label = f"telemetry {name} ({TELEMETRY_ROBOTS} robots in turns)"
        if deferred:
            label += f", {batches} transactions"
        rates[deferred] = _row(report, label, samples, wall)
    report.notes.append(
        f"PostGIS telemetry batched vs one transaction per update: "
        f"{rates[True] / rates[False]:.1f}x the updates per second (same run; batch_size "
        f"{DEFAULT_SIZE}, batch_interval {DEFAULT_INTERVAL} s)")
    return [f"bench-batch-{d}-{r}" for d in (0, 1) for r in range(TELEMETRY_ROBOTS)]
