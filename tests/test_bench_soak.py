"""`mrss bench soak`'s growth judgement can fail: a growing series misses its bound, a
flat one (noise, restarts) holds, and a full-size report with a leak exits 1."""

from __future__ import annotations

import random
from pathlib import Path

from mrss.bench import soak
from mrss.bench.report import BenchReport
from mrss.bench.soak_growth import Bound, Series, pooled_slope
from mrss.bench.soak_sampler import FileKind, Resource, Sampler
from mrss.config.kinds import ComponentKind
from mrss.config.loader import load_project

SPEEDUP = 16.0
RSS = soak.BOUNDS[Resource.RSS]


def _series(value: float | object, seconds: int = 900, every: int = 10,
            restart_every: int = 0, seed: int = 1) -> Series:
    """Samples of `value(t, rng)` every `every` s; a new pid every `restart_every` s."""
    rng = random.Random(seed)
    series = Series()
    for t in range(0, seconds, every):
        pid = 100 + (t // restart_every if restart_every else 0)
        series.add(float(t), value(t, rng), pid)  # type: ignore[operator]
    return series


def test_a_flat_noisy_series_holds_its_bound() -> None:
    flat = _series(lambda t, rng: 120.0 + rng.uniform(-3, 3))
    g = flat.growth(warmup=120, settle=60, speedup=SPEEDUP)
    assert g.holds(RSS), g
    assert abs(g.slope or 0) < RSS.per_hour


def test_a_leak_of_a_megabyte_a_minute_fails() -> None:
    # 1 MB per wall minute at 16x: 3.75 MB per simulated hour, above the 2 MB bound
    leaking = _series(lambda t, rng: 120.0 + t / 60 + rng.uniform(-3, 3))
    g = leaking.growth(warmup=120, settle=60, speedup=SPEEDUP)
    assert g.slope is not None and 3.0 < g.slope < 4.5
    assert not g.holds(RSS)


def test_a_late_step_up_fails_on_the_halves_though_the_slope_is_small() -> None:
    step = _series(lambda t, rng: 100.0 + (20.0 if t >= 850 else 0.0))
    g = step.growth(warmup=120, settle=60, speedup=SPEEDUP)
    bound = Bound("MB", per_hour=100.0, halves=16.0, reference="test")
    assert g.halves == 20.0
    assert not g.holds(bound)


def test_restarts_are_not_growth_but_a_leak_in_every_incarnation_is() -> None:
    # each incarnation starts low after its warm-up and stays flat: holds
    sawtooth = _series(lambda t, rng: 80.0 + 40.0 * ((t // 300) % 2), restart_every=300)
    assert sawtooth.growth(warmup=0, settle=30, speedup=SPEEDUP).holds(RSS)
    # every incarnation leaks 10 MB per wall minute from the same start: a line through
    # all samples is flat, the line per incarnation is not
    leak = _series(lambda t, rng: 80.0 + (t % 300) / 6, restart_every=300)
    g = leak.growth(warmup=0, settle=30, speedup=SPEEDUP)
    assert g.slope is not None and g.slope > 30
    assert not g.holds(RSS)


def test_a_series_too_short_to_judge_holds_nothing() -> None:
    short = _series(lambda t, rng: 1.0, seconds=150)
    g = short.growth(warmup=120, settle=60, speedup=SPEEDUP)
    assert g.slope is None and not g.holds(RSS)
    assert pooled_slope([]) is None


def _sampler_with(rss: Series, log: Series) -> Sampler:
    sampler = Sampler(Path("/nonexistent"), every=10.0)
    flat = _series(lambda t, rng: 10.0)
    sampler.processes["reasoner"] = {Resource.RSS: rss, Resource.FDS: flat,
                                     Resource.THREADS: flat}
    sampler.files["mrss.log"] = log
    return sampler


def _full_report(sampler: Sampler) -> BenchReport:
    report = BenchReport("soak", soak.COLUMNS, quick=False)
    soak.judge(report, sampler, soak.FULL)
    return report


def test_a_full_size_report_exits_1_on_a_leak_and_names_the_component() -> None:
    leaking = _sampler_with(_series(lambda t, rng: 120.0 + t / 60),
                            _series(lambda t, rng: 1.0 + t / 100_000))
    report = _full_report(leaking)
    assert report.exit_status() == 1
    missed = [t.description for t in report.targets if not t.met]
    assert any("rss" in d and "(reasoner)" in d for d in missed), missed
    assert report.rows[0][0] == "reasoner" and report.rows[0][-1] == "no: rss"


def test_a_full_size_report_of_flat_series_exits_0() -> None:
    flat = _sampler_with(_series(lambda t, rng: 120.0 + rng.uniform(-2, 2)),
                         _series(lambda t, rng: 1.0))
    report = _full_report(flat)
    unjudged = {FileKind.JOURNAL, FileKind.LEDGER, FileKind.WORLDMODEL}  # no such file here
    missed = [t.description for t in report.targets if not t.met]
    assert all(any(k.value in d for k in unjudged) for d in missed), missed
    assert not any("rss" in d or "log" in d for d in missed)
    assert all(row[-1] == "yes" for row in report.rows)


def test_files_are_sized_by_kind_with_their_side_and_rotated_files(tmp_path: Path) -> None:
    for name, size in (("rcl-journal.sqlite3", 4096), ("rcl-journal.sqlite3-wal", 1000),
                       ("reasoner-percepts.sqlite3", 2048), ("worldmodel.sqlite", 10),
                       ("mrss.log", 7), ("mrss.log.1", 30), ("mrss.log.2", 40),
                       ("mrss.log.lock", 0), ("chaos-history.jsonl", 99), ("broker.url", 5)):
        (tmp_path / name).write_bytes(b"x" * size)
    sampler = Sampler(tmp_path, every=1.0, ignore=("chaos-history.jsonl",))
    sizes = sampler._file_sizes()
    assert sizes == {"rcl-journal.sqlite3": 5096, "reasoner-percepts.sqlite3": 2048,
                     "worldmodel.sqlite": 10, "mrss.log": 77}  # with its rotated files
    assert [FileKind.of(n) for n in sorted(sizes)] == [
        FileKind.LOG, FileKind.JOURNAL, FileKind.LEDGER, FileKind.WORLDMODEL]


def test_the_soaks_project_compacts_its_journal_within_the_run(tmp_path: Path) -> None:
    config = load_project(soak.PROJECT, soak.project(tmp_path, soak.FULL))
    (rcl,) = config.of_kind(ComponentKind.RCL)
    assert rcl.options["journal_keep_seconds"] == soak.FULL.journal_keep_s < soak.FULL.wall_s
    assert rcl.options["journal_compact_period"] == soak.FULL.journal_compact_s
    assert rcl.options["journal_keep_last"] == soak.JOURNAL_KEEP_LAST
    (shipped,) = load_project(soak.PROJECT).of_kind(ComponentKind.RCL)
    assert rcl.options["robots"] == shipped.options["robots"]  # the rest of its table kept
    assert {"uav1", "ugv1"} <= rcl.options["robots"].keys()
    assert soak.FULL.sim_hours >= soak.TARGET_SIM_HOURS
