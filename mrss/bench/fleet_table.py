"""The table of `mrss bench fleet`: each fleet size and scheduling's windows as one row,
with the worst window and the share of windows meeting each target.

The N = 100 fleet's e2e p99 is bimodal from run to run (docs/e2e.md), so one window per
size says little: each row summarises several windows of the same system. A sample that
did not come within the bench's wait (a skill start, a world model write) is late: it
is counted as lost and ranks above every sample in the percentiles, so a p99 that falls
on one reads "late" instead of leaving it out.
"""

from __future__ import annotations

import math
from collections import Counter
from dataclasses import dataclass, field

from mrss.bench.fleet_project import Scheduling
from mrss.bench.report import BenchReport, Relation
from mrss.bench.restart import percentile

TARGET_ROBOTS = (100, 400)  # the sizes the performance issues set targets for
E2E_P99_MS = 20.0
LAG_P99_MS = 200.0
COLUMNS = ["robots", "scheduling", "windows", "assignments", "e2e p50 ms",
           "e2e p99 ms (worst window)", f"windows e2e p99 <= {E2E_P99_MS:g} ms", "telemetry",
           "lag p50 ms", "lag p99 ms (worst window)", f"windows lag p99 <= {LAG_P99_MS:g} ms",
           "lost", "busiest component (CPU %, RSS MB)", "msgs/s"]


@dataclass
class Sample:
    """What one fleet size measured."""

    robots: int
    window_s: float = 0.0
    e2e_ms: list[float] = field(default_factory=list)
    lag_ms: list[float] = field(default_factory=list)
    assigned: int = 0
    telemetry: int = 0
    written: int = 0
    bus_dropped: int = 0
    batches: list[int] = field(default_factory=list)
    topics: Counter[str] = field(default_factory=Counter)
    cpu: dict[str, float] = field(default_factory=dict)
    rss_mb: dict[str, float] = field(default_factory=dict)
    threads: dict[str, int] = field(default_factory=dict)

    @property
    def lost_assignments(self) -> int:
        return self.assigned - len(self.e2e_ms)

    @property
    def lost_telemetry(self) -> int:
        return self.telemetry - self.written


@dataclass
class Windows:
    """The windows measured on one system: `robots` robots scheduled as `scheduling`."""

    robots: int
    scheduling: Scheduling
    samples: list[Sample] = field(default_factory=list)
    load: tuple[float, float] = (0.0, 0.0)  # load average before and after

    def e2e_p99s(self) -> list[float]:
        return [_p(s.e2e_ms, 99, s.lost_assignments) for s in self.samples]

    def lag_p99s(self) -> list[float]:
        return [_p(s.lag_ms, 99, s.lost_telemetry) for s in self.samples]

    def lost(self) -> int:
        return sum(s.lost_assignments + s.lost_telemetry + s.bus_dropped
                   for s in self.samples)


def _p(samples: list[float], q: float, late: int) -> float:
    """The percentile with late samples counted (NaN when there was nothing at all)."""
    return percentile(samples, q, late) if samples or late else math.nan


def worst(values: list[float]) -> float:
    """The worst of the windows' figures (NaN counts as worst: nothing measured)."""
    if not values or any(math.isnan(v) for v in values):
        return math.nan
    return max(values)


def share(values: list[float], bound: float) -> str:
    """'k/n': how many of the windows' figures are within `bound`."""
    return f"{sum(1 for v in values if v <= bound)}/{len(values)}"


def add(report: BenchReport, w: Windows) -> None:
    """`w`'s row."""
    e2e = [x for s in w.samples for x in s.e2e_ms]
    lag = [x for s in w.samples for x in s.lag_ms]
    late_e2e = sum(s.lost_assignments for s in w.samples)
    late_lag = sum(s.lost_telemetry for s in w.samples)
    cpu = _mean_cpu(w.samples)
    system = [name for name in cpu if name not in ("bench", "mosquitto")]
    busiest = max(system, key=lambda n: cpu[n]) if system else None
    rss = max((s.rss_mb.get(busiest, 0.0) for s in w.samples), default=0.0) if busiest else 0
    seconds = sum(s.window_s for s in w.samples)
    report.add_row(
        w.robots, w.scheduling.value, len(w.samples), sum(s.assigned for s in w.samples),
        _cell(_p(e2e, 50, late_e2e)), _cell(worst(w.e2e_p99s())),
        share(w.e2e_p99s(), E2E_P99_MS), sum(s.telemetry for s in w.samples),
        _cell(_p(lag, 50, late_lag)), _cell(worst(w.lag_p99s())),
        share(w.lag_p99s(), LAG_P99_MS),
        f"{late_e2e} assignments, {late_lag} records, "
        f"{sum(s.bus_dropped for s in w.samples)} bus",
        f"{busiest} ({cpu[busiest]:.0f} %, {rss:.0f})" if busiest else None,
        sum(sum(s.topics.values()) for s in w.samples) / seconds if seconds else None)


def _cell(value: float) -> float | None:
    return None if math.isnan(value) else value


def _mean_cpu(samples: list[Sample]) -> dict[str, float]:
    names = {name for s in samples for name in s.cpu}
    return {name: sum(s.cpu.get(name, 0.0) for s in samples) / len(samples)
            for name in names}


def targets(report: BenchReport, rows: list[Windows]) -> None:
    """The performance issues' fleet targets, on the tuned N = 100 and N = 400 systems
    (as the issues set them), each over the worst of its windows."""
    for w in rows:
        if w.robots not in TARGET_ROBOTS or w.scheduling is not Scheduling.TUNED:
            continue
        label = f"{w.robots} robots at 5 Hz, {w.scheduling.value}"
        n = len(w.samples)
        report.target(f"{label}: e2e p99 <= {E2E_P99_MS:g} ms in every window",
                      worst(w.e2e_p99s()), Relation.AT_MOST, E2E_P99_MS,
                      f"the worst of {n} windows; late starts count as late")
        report.target(f"{label}: telemetry -> world model lag p99 <= {LAG_P99_MS:g} ms "
                      "in every window", worst(w.lag_p99s()), Relation.AT_MOST, LAG_P99_MS,
                      f"the worst of {n} windows; late writes count as late")
        report.target(f"{label}: nothing lost", float(w.lost()), Relation.AT_MOST, 0.0,
                      f"assignments, records and bus drops over {n} windows")


def notes(report: BenchReport, w: Windows) -> None:
    """Where `w`'s CPU went, how the world model writes were batched, the busiest topics."""
    tag = f"N={w.robots} {w.scheduling.value}"
    report.notes.append(f"{tag}: load average {w.load[0]:.2f} before, {w.load[1]:.2f} after")
    cpu = _mean_cpu(w.samples)
    last = w.samples[-1] if w.samples else Sample(robots=w.robots)
    report.notes.append(f"{tag} CPU % of one core (mean of the windows) / RSS MB / threads: "
                        + ", ".join(f"{name} {cpu[name]:.0f}/{last.rss_mb.get(name, 0):.0f}/"
                                    f"{last.threads.get(name, 0)}"
                                    for name in sorted(cpu, key=lambda n: -cpu[n])))
    batches = [float(b) for s in w.samples for b in s.batches]
    if batches:
        report.notes.append(f"{tag} world model writes per request: mean "
                            f"{sum(batches) / len(batches):.1f}, p99 "
                            f"{percentile(batches, 99):.0f}")
    topics = sum((s.topics for s in w.samples), start=Counter())
    seconds = sum(s.window_s for s in w.samples) or 1.0
    report.notes.append(f"{tag} msgs/s by topic: " + ", ".join(
        f"{topic} {count / seconds:.0f}" for topic, count in topics.most_common(8)))
    report.notes.append(f"{tag} e2e p99 per window, ms: "
                        + ", ".join(_text(v) for v in w.e2e_p99s()))


def _text(value: float) -> str:
    return "late" if math.isinf(value) else "-" if math.isnan(value) else f"{value:.1f}"
