"""`mrss bench soak`: hours of simulated mission under operator traffic and faults, and
whether anything grows.

It runs a `mrss chaos` campaign on the shipped wildfire project (`mrss.chaos.runner`: the
project's own operator traffic from its chaos.py, a seeded fault of any kind every few
simulated minutes, the simulators sped up by `Size.speedup` through $MRSS_SIM_SPEEDUP)
for `Size.wall_s` seconds of faults, while `mrss.bench.soak_sampler` samples every
process under the root supervisor (RSS, open file descriptors, threads) and the files
the components keep in the run folder (action journal, percept ledger, world model,
logs). Simulated time is wall time x speedup: the simulators' flight, driving, battery
and water run that much faster, so a goal is covered that much sooner and the operator's
goals and the faults come that often per simulated hour (telemetry and heartbeats keep
their wall-clock rates, docs/robots.md).

Growth is judged per component and resource, on the steady part of the run
(`mrss.bench.soak_growth`: slope per simulated hour with a line per incarnation, and the
second half's largest value against the first half's), against the bounds of `BOUNDS`.
Each resource is one pair of target rows: its worst component's figures. One more
target: the chaos verdict of the same campaign holds (`mrss.chaos.checker`, which knows
the actions the journal's compaction dropped by their terminal status on the bus).
"""

from __future__ import annotations

import os
import re
import shutil
import tempfile
from dataclasses import dataclass
from pathlib import Path

from mrss.bench.report import BenchReport, Relation
from mrss.bench.soak_growth import HOUR, Bound, Growth, Series
from mrss.bench.soak_sampler import FileKind, Resource, Sampler
from mrss.chaos import history as chaos_history
from mrss.chaos import runner
from mrss.chaos.campaign import Range
from mrss.chaos.checker import Outcome, check
from mrss.chaos.history import FILE_NAME
from mrss.config.projects import PROJECT_FILE, project_path
from mrss.sim.component import SPEEDUP_ENV

PROJECT = "wildfire"
TARGET_SIM_HOURS = 4.0  # issue 29: "hours, not minutes"


@dataclass(frozen=True)
class Size:
    """How long and how hard one soak runs (wall seconds unless said)."""

    wall_s: float  # the faults phase; the run is longer by start-up and the settling
    speedup: float  # simulated seconds per wall second
    every: float  # one sample per `every` s
    fault_interval: Range  # a fault after every such pause
    fault_duration: Range  # how long a timed fault lasts
    operator_every: float  # the operator's pace (chaos.py draws 0.5x..1.5x of it)
    warmup: float  # the first `warmup` s of samples are not judged
    settle: float  # nor the first `settle` s of each incarnation of a process
    journal_keep_s: float  # the RCL's journal retention in this run (see `project`)
    journal_compact_s: float  # ... and how often it compacts

    @property
    def sim_hours(self) -> float:
        return self.wall_s * self.speedup / HOUR

    @property
    def faults(self) -> int:
        return int(self.wall_s / (sum(self.fault_interval) / 2))


# 15 min of faults at 16x: 4 simulated hours, a fault every 2.7-5.3 simulated minutes
# (10-20 s), an operator step every ~5 simulated minutes. About 17 min of wall clock.
FULL = Size(wall_s=900.0, speedup=16.0, every=10.0, fault_interval=(10.0, 20.0),
            fault_duration=(2.0, 8.0), operator_every=20.0, warmup=120.0, settle=60.0,
            journal_keep_s=180.0, journal_compact_s=30.0)
QUICK = Size(wall_s=40.0, speedup=16.0, every=2.0, fault_interval=(8.0, 12.0),
             fault_duration=(1.0, 3.0), operator_every=8.0, warmup=10.0, settle=8.0,
             journal_keep_s=20.0, journal_compact_s=5.0)

JOURNAL_KEEP_LAST = 20  # the newest ended actions compaction always keeps, in this run
RCL_TABLE = re.compile(r"^\[components\.rcl\][^\n]*\n", re.MULTILINE)
DAY = "a simulated day's budget"
BOUNDS: dict[Resource | FileKind, Bound] = {
    Resource.RSS: Bound("MB", per_hour=2.0, halves=16.0,
                        reference=f"{DAY}: 48 MB per process; halves: 16 MB of noise"),
    Resource.FDS: Bound("fds", per_hour=0.5, halves=4.0,
                        reference="not growing: 12 per simulated day; halves: a few reconnects"),
    Resource.THREADS: Bound("threads", per_hour=0.5, halves=2.0,
                            reference="not growing: 12 per simulated day; halves: a pool's spare"),
    FileKind.JOURNAL: Bound("MB", per_hour=0.5, halves=1.0,
                            reference="bounded by compaction (the RCL's timer)"),
    FileKind.LEDGER: Bound("MB", per_hour=0.5, halves=1.0,
                           reference="bounded by compaction (the reasoner's ledger)"),
    FileKind.WORLDMODEL: Bound("MB", per_hour=0.5, halves=1.0,
                               reference="a world of a few areas and hotspots"),
    FileKind.LOG: Bound("MB", per_hour=1.0, halves=4.0,
                        reference=f"{DAY}: 24 MB of log"),
}
COLUMNS = ["component / file", "incarnations / kind", "MB start", "MB end",
           "MB per sim h", "MB 2nd-1st half", "fds start-end", "fds 2nd-1st half",
           "threads start-end", "threads 2nd-1st half", "within bounds"]


def run(quick: bool, size: Size | None = None, seed: int = 29) -> BenchReport:
    size = size or (QUICK if quick else FULL)
    report = BenchReport("soak", COLUMNS, quick=quick)
    tmp = Path(tempfile.mkdtemp(prefix="mrss-bench-soak-"))
    run_dir = tmp / "run"
    options = runner.Options(
        project=PROJECT, projects=project(tmp / "projects", size), run_dir=run_dir,
        faults=size.faults, seed=seed,
        interval=size.fault_interval, duration=size.fault_duration,
        operator_every=size.operator_every, env={SPEEDUP_ENV: f"{size.speedup:g}"})
    sampler = Sampler(run_dir, size.every,
                      ignore=(FILE_NAME, runner.SUPERVISE_LOG))
    load = os.getloadavg()[0]
    lines: list[str] = []
    try:
        sampler.start()
        history = runner.run(options, say=lines.append, settled=sampler.stop)
        verdict = check(chaos_history.load(history))
    finally:
        sampler.stop()
        shutil.rmtree(tmp, ignore_errors=True)
    judge(report, sampler, size)
    report.notes.append(
        f"{PROJECT} under `mrss supervise`, simulators at {size.speedup:g}x: "
        f"{size.wall_s:g} s of faults = {size.sim_hours:.2f} simulated h; sampled "
        f"{sampler.elapsed:.0f} s (from start-up until settled after the faults), "
        f"{sampler.samples} samples "
        f"every {size.every:g} s; {size.faults} faults (seed {seed}, every "
        f"{size.fault_interval[0]:g}-{size.fault_interval[1]:g} s), an operator step every "
        f"~{size.operator_every:g} s. Judged after {size.warmup:g} s and {size.settle:g} s "
        f"into each incarnation. Load average {load:.2f} before, {os.getloadavg()[0]:.2f} "
        "after.")
    report.notes.append(
        f"the RCL's journal retention in this run: {size.journal_keep_s:g} s, the newest "
        f"{JOURNAL_KEEP_LAST} ended actions, compacted every {size.journal_compact_s:g} s "
        "(shipped: a day, 1000, 600 s; `mrss bench journal` sizes that one)")
    broken = [f"{v.invariant} {v.subject}" + (" (" + "; ".join(v.evidence) + ")"
                                               if v.evidence else "")
              for v in verdict.violations]
    report.check(f"chaos verdict of the same run holds ({verdict.outcome.value})",
                 verdict.outcome is Outcome.HOLDS)
    if broken or verdict.missing:
        report.notes.append("chaos verdict: " + "; ".join(
            broken[:5] + [f"missing: {m}" for m in verdict.missing[:3]] + lines[-2:]))
    return report


def project(projects: Path, size: Size) -> Path:
    """A copy of the shipped project under `projects/`, its RCL compacting the journal
    within the run: the shipped retention (a day of wall clock, the newest 1000 ended
    actions) is longer than a soak, which would then only see the journal fill. The
    folder holding it."""
    copy = projects / PROJECT
    shutil.copytree(project_path(PROJECT), copy)
    toml = copy / PROJECT_FILE
    text, found = RCL_TABLE.subn(
        lambda m: m[0] + f"journal_keep_seconds = {size.journal_keep_s}\n"
        f"journal_keep_last = {JOURNAL_KEEP_LAST}\n"
        f"journal_compact_period = {size.journal_compact_s}\n",
        toml.read_text(encoding="utf-8"), count=1)
    if not found:
        raise RuntimeError(f"{toml}: no [components.rcl] table to set the retention in")
    toml.write_text(text, encoding="utf-8")
    return projects


def judge(report: BenchReport, sampler: Sampler, size: Size) -> None:
    """The table's rows and the targets: per resource, its worst series against BOUNDS."""
    worst: dict[Resource | FileKind, list[tuple[str, Growth]]] = {k: [] for k in BOUNDS}

    def growth(series: Series) -> Growth:
        return series.growth(size.warmup, size.settle, size.speedup)

    for name in sorted(sampler.processes):
        series = sampler.processes[name]
        figures = {r: growth(series[r]) for r in Resource}
        for r, g in figures.items():
            worst[r].append((name, g))
        rss, fds, threads = (figures[r] for r in Resource)
        incarnations = len({p.pid for p in series[Resource.RSS].points})
        report.add_row(name, incarnations, rss.first, rss.last, rss.slope, rss.halves,
                       _span(fds), fds.halves, _span(threads), threads.halves,
                       _held(figures))
    for name in sorted(sampler.files):
        kind = FileKind.of(name)
        assert kind is not None  # the sampler keeps only files of a kind
        g = growth(sampler.files[name])
        worst[kind].append((name, g))
        report.add_row(name, kind.value, g.first, g.last, g.slope, g.halves, None, None,
                       None, None, _held({kind: g}))
    report.target(f"simulated mission >= {TARGET_SIM_HOURS:g} h", size.sim_hours,
                  Relation.AT_LEAST, TARGET_SIM_HOURS, "issue 29: hours, not minutes")
    for key, bound in BOUNDS.items():
        judged = [(n, g) for n, g in worst[key] if g.slope is not None and g.halves is not None]
        unjudged = [n for n, g in worst[key] if g.slope is None or g.halves is None]
        extra = f"; too short to judge: {', '.join(unjudged)}" if unjudged else ""
        if judged:
            name, g = max(judged, key=lambda item: item[1].slope or 0.0)
            slope: float | None = g.slope
            name_h, g_h = max(judged, key=lambda item: item[1].halves or 0.0)
            halves: float | None = g_h.halves
        else:
            slope = halves = None
            name = name_h = "none judged"
        report.target(f"{key.value}: growth per simulated hour, worst series ({name})",
                      slope, Relation.AT_MOST, bound.per_hour,
                      f"{bound.unit}/sim h; {bound.reference}{extra}")
        report.target(f"{key.value}: 2nd half's max - 1st half's, worst series ({name_h})",
                      halves, Relation.AT_MOST, bound.halves, bound.unit)


def _span(g: Growth) -> str | None:
    if g.first is None or g.last is None:
        return None
    return f"{g.first:.0f}-{g.last:.0f}"


def _held(figures: dict[Resource, Growth] | dict[FileKind, Growth]) -> str:
    missed = [k.value for k, g in figures.items() if not g.holds(BOUNDS[k])]
    return "yes" if not missed else "no: " + ", ".join(missed)
