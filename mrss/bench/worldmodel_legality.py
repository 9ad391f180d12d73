"""Rows of `mrss bench worldmodel` for the AMADEE-24 deployment: the legality check of
projects/amadee (its rules, legality.py) over a big world, and telemetry writes.

The world: the habitat with the rules' parameters (a communication zone wide enough
that every rule runs), `zones` 50 m squares (no-go and protected alternately) over a
22 x 22 km area around it, and `objects` other objects: terrain tiles (11 x 11 nodes
of elevation each), crew on EVA, robots, and two time windows that are closed. A check
is `legality.judge(action, world)` on the world model as the data layer reaches it in
one process (`LocalWorldModel`): the rover is placed at a random point first (not
timed), and the action is a drive of 50 to 400 m (60 %), a science task where it stands
(35 %) or the way home (5 %).

Telemetry: `robots` robots each sending a position, speed, heading and battery, in
turns, upserted through the world model service (what the data layer's `on_telemetry`
asks of it): the write rate it sustains against the 5 Hz x 100 robots = 500 writes/s
the issue asks for.
"""

from __future__ import annotations

import math
import random
import time
from collections import Counter
from collections.abc import Callable
from functools import partial
from types import ModuleType
from typing import Any

from mrss.actors.worldmodel.local import LocalWorldModel
from mrss.actors.worldmodel.model import WorldModel
from mrss.actors.worldmodel.store import WorldStore
from mrss.bench.report import BenchReport

HOME = (39.7700, 44.8000)
HALF_LAT, HALF_LON = 0.1, 0.13           # ~11 km each way
ZONE_DEG = 0.0005                        # ~55 x 43 m
TILES = 10                               # terrain tiles per side
ROVER = "rover1"
TELEMETRY_HZ, TELEMETRY_ROBOTS = 5, 100


def legality_module() -> ModuleType | None:
    """projects/amadee/legality.py, or None when the amadee project is not here."""
    from mrss.config.projects import project_path
    from mrss.errors import MrssError
    from mrss.runtime.loader import import_project_module
    try:
        return import_project_module(project_path("amadee"), "legality.py")
    except MrssError:
        return None


def _square(lon: float, lat: float, size: float) -> dict[str, Any]:
    ring = [[lon, lat], [lon + size, lat], [lon + size, lat + size], [lon, lat + size],
            [lon, lat]]
    return {"type": "Polygon", "coordinates": [ring]}


def _elevation(lat: float, lon: float) -> float:
    y, x = (lat - HOME[0]) * 111_000, (lon - HOME[1]) * 85_000
    return 40 * math.sin(x / 900) * math.cos(y / 1100) + 0.002 * x


def world_objects(zones: int, objects: int) -> list[dict[str, Any]]:
    """The habitat, `zones` zones and `objects` other objects (JSON, as seeded)."""
    rnd = random.Random(11)
    out: list[dict[str, Any]] = [{
        "id": "habitat", "kind": "base", "position": {"lat": HOME[0], "lon": HOME[1]},
        "attributes": {"comm_radius_m": 30_000, "crew_safety_m": 25, "energy_per_m": 0.002,
                       "battery_reserve": 15, "max_slope_deg": 15}}]
    for i in range(zones):
        lat = HOME[0] + rnd.uniform(-HALF_LAT, HALF_LAT)
        lon = HOME[1] + rnd.uniform(-HALF_LON, HALF_LON)
        out.append({"id": f"bench-zone-{i}", "kind": "no_go" if i % 2 else "protected",
                    "geometry": _square(lon, lat, ZONE_DEG)})
    tiles = min(TILES * TILES, objects // 10)
    side = max(1, math.isqrt(tiles))
    dlat, dlon = 2 * HALF_LAT / side, 2 * HALF_LON / side
    for t in range(side * side):
        south, west = HOME[0] - HALF_LAT + (t // side) * dlat, HOME[1] - HALF_LON + (
            t % side) * dlon
        rows = [[round(_elevation(south + dlat * r / 10, west + dlon * c / 10), 2)
                 for c in range(11)] for r in range(11)]
        out.append({"id": f"bench-terrain-{t}", "kind": "terrain",
                    "attributes": {"elevation_m": rows},
                    "geometry": {"type": "Polygon", "coordinates": [[
                        [west, south], [west + dlon, south], [west + dlon, south + dlat],
                        [west, south + dlat], [west, south]]]}})
    for n, start in enumerate((-7200.0, 86_400.0 * 400)):
        out.append({"id": f"bench-window-{n}", "kind": "time_window",
                    "attributes": {"start": _iso(time.time() + start),
                                   "end": _iso(time.time() + start + 600)}})
    rest = objects - side * side - 2
    for i in range(max(0, rest)):
        lat = HOME[0] + rnd.uniform(-HALF_LAT, HALF_LAT)
        lon = HOME[1] + rnd.uniform(-HALF_LON, HALF_LON)
        out.append({"id": f"bench-obj-{i}", "kind": "crew" if i % 8 == 0 else "robot",
                    "position": {"lat": lat, "lon": lon}})
    return out


def _iso(epoch: float) -> str:
    return time.strftime("%Y-%m-%dT%H:%M:%SZ", time.gmtime(epoch))


def _action(rnd: random.Random, i: int) -> tuple[tuple[float, float], str]:
    """Where the rover stands, and the action it is asked to do."""
    here = (HOME[0] + rnd.uniform(-HALF_LAT, HALF_LAT) * 0.9,
            HOME[1] + rnd.uniform(-HALF_LON, HALF_LON) * 0.9)
    roll = rnd.random()
    if roll < 0.60:
        metres, bearing = rnd.uniform(50, 400), rnd.uniform(0, 2 * math.pi)
        lat = here[0] + metres * math.cos(bearing) / 111_000
        lon = here[1] + metres * math.sin(bearing) / 85_000
        return here, f"drive({ROVER},g{i},{lat:.6f},{lon:.6f})"
    if roll < 0.95:
        what = ("image", "spectrum", "radar", "sample")[i % 4]
        return here, f"{what}({ROVER},g{i})"
    return here, f"return_home({ROVER},g{i})"


def percentile_ms(samples: list[float], q: float) -> float:
    """The q-quantile of durations in seconds, in milliseconds."""
    ordered = sorted(samples)
    return ordered[min(len(ordered) - 1, int(q * len(ordered)))] * 1e3


def add_timed_row(report: BenchReport, backend: str, what: str,
                  samples: list[float]) -> float:
    """A row of durations: n, p50, p95, p99 (ms) and the rate per second; the p99."""
    p99 = percentile_ms(samples, 0.99)
    report.add_row(backend, what, len(samples), round(percentile_ms(samples, 0.5), 3),
                   round(percentile_ms(samples, 0.95), 3), round(p99, 3),
                   round(len(samples) / sum(samples)) if sum(samples) > 0 else None)
    return p99


def _time(call: Callable[[], object]) -> float:
    start = time.perf_counter()
    call()
    return time.perf_counter() - start


def measure_legality(report: BenchReport, backend: str, store: WorldStore, legality: Any,
                     zones: int, objects: int, checks: int) -> tuple[float, list[str]]:
    """Load the world (its load rate a row), time `checks` checks; (p99 ms, ids made)."""
    world = LocalWorldModel(WorldModel(store))
    seeded = world_objects(zones, objects)
    loads = [_time(partial(world.upsert, obj)) for obj in seeded]
    add_timed_row(report, backend, f"load {zones} zones + {objects} objects (upsert)", loads)
    rnd = random.Random(5)
    samples: list[float] = []
    rules: Counter[str] = Counter()
    for i in range(checks):
        here, action = _action(rnd, i)
        world.upsert({"id": ROVER, "kind": "robot", "position": {"lat": here[0],
                                                                  "lon": here[1]},
                      "attributes": {"speed": 0.0, "battery": 90.0}})
        start = time.perf_counter()
        verdict = legality.judge(action, world)
        samples.append(time.perf_counter() - start)
        rules[verdict.rule or "legal"] += 1
    p99 = add_timed_row(report, backend,
                        f"legality check ({zones} zones, {objects} objects)", samples)
    share = ", ".join(f"{rule} {100 * n / checks:.0f} %" for rule, n in rules.most_common())
    report.notes.append(f"{backend} verdicts: {share}")
    return p99, [str(o["id"]) for o in seeded] + [ROVER]


def measure_telemetry(report: BenchReport, backend: str, store: WorldStore,
                      writes: int) -> tuple[float, list[str]]:
    """Telemetry upserts of TELEMETRY_ROBOTS robots in turns; (writes per s, ids made)."""
    world = LocalWorldModel(WorldModel(store))
    rnd = random.Random(3)
    samples = []
    for i in range(writes):
        robot = i % TELEMETRY_ROBOTS
        record = {"id": f"bench-tele-{robot}", "kind": "robot",
                  "position": {"lat": HOME[0] + rnd.uniform(-0.01, 0.01),
                               "lon": HOME[1] + rnd.uniform(-0.01, 0.01)},
                  "attributes": {"speed": round(rnd.uniform(0, 1.5), 2),
                                 "heading": round(rnd.uniform(0, 360), 1),
                                 "battery": round(100 - i / writes * 20, 2)}}
        samples.append(_time(partial(world.upsert, record)))
    add_timed_row(report, backend,
                  f"telemetry upsert ({TELEMETRY_ROBOTS} robots in turns)", samples)
    return writes / sum(samples), [f"bench-tele-{r}" for r in range(TELEMETRY_ROBOTS)]


def legality_and_telemetry(report: BenchReport, backend: str, store: WorldStore, *,
                           quick: bool, p99_target_ms: float) -> list[str]:
    """Both measurements on one store, with their targets; the ids they wrote."""
    zones, objects, checks, writes = (400, 40, 60, 300) if quick else (10_000, 1_000,
                                                                        1_000, 5_000)
    made: list[str] = []
    legality = legality_module()
    if legality is None:
        report.notes.append("legality check not measured: no amadee project here "
                            "($MRSS_PROJECTS or ./projects)")
    else:
        p99, ids = measure_legality(report, backend, store, legality, zones, objects,
                                    checks)
        made += ids
        report.check(f"{backend}: legality check p99 <= {p99_target_ms:g} ms "
                     f"({zones} zones, {objects} objects): {p99:.1f} ms",
                     p99 <= p99_target_ms)
    rate, ids = measure_telemetry(report, backend, store, writes)
    made += ids
    needed = TELEMETRY_HZ * TELEMETRY_ROBOTS
    report.check(f"{backend}: telemetry {TELEMETRY_HZ} Hz x {TELEMETRY_ROBOTS} robots = "
                 f"{needed} writes/s sustained: {rate:.0f} writes/s", rate >= needed)
    return made
