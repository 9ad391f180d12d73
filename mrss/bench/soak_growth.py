"""Whether a resource grows over a soak: the judgement of `mrss bench soak`, as data.

A series is one resource of one component (RSS, open files, threads) or one file of the
run folder, sampled over the run: (wall seconds since the first sample, value, the pid
that had it). Growth is judged on its steady part only: after the run's warm-up, and for
a process only once each incarnation has run `settle` seconds (a restarted component
loads its modules and fills its caches again, which is not growth).

Two figures, each with its bound (`Bound`):

* slope: a least-squares line through the steady samples, one intercept per incarnation
  and a common slope (a restart resets a process's memory; a leak shows as the same
  slope in every incarnation), in units per *simulated* hour (wall seconds x speedup);
* halves: the largest value of the second half of the steady part minus the largest of
  the first half (what a slope of a noisy series may hide: a step up late in the run).

A series too short to judge (fewer than MIN_POINTS steady samples, or a half with none)
gives no figure, and a target without a figure is not met.
"""

from __future__ import annotations

from collections import defaultdict
from dataclasses import dataclass, field

MIN_POINTS = 4
HOUR = 3600.0


@dataclass(frozen=True)
class Point:
    t: float  # wall seconds since the soak's first sample
    value: float
    pid: int = 0  # the process that had it (0: a file); a new pid is a new incarnation


@dataclass(frozen=True)
class Bound:
    """How much a resource may grow: `per_hour` units per simulated hour (slope), and
    `halves` units from the first half's largest value to the second half's."""

    unit: str
    per_hour: float
    halves: float
    reference: str


@dataclass(frozen=True)
class Growth:
    """The figures of one series (None: too few steady samples to say)."""

    first: float | None  # the first steady value
    last: float | None  # the last value
    slope: float | None  # units per simulated hour
    halves: float | None  # second half's max - first half's max

    def holds(self, bound: Bound) -> bool:
        return (self.slope is not None and self.halves is not None
                and self.slope <= bound.per_hour and self.halves <= bound.halves)


@dataclass
class Series:
    points: list[Point] = field(default_factory=list)

    def add(self, t: float, value: float, pid: int = 0) -> None:
        self.points.append(Point(t, value, pid))

    def steady(self, warmup: float, settle: float) -> list[Point]:
        """The samples after `warmup` s of the run and `settle` s into their incarnation."""
        born: dict[int, float] = {}
        for p in self.points:
            born.setdefault(p.pid, p.t)
        return [p for p in self.points
                if p.t >= warmup and (p.pid == 0 or p.t - born[p.pid] >= settle)]

    def growth(self, warmup: float, settle: float, speedup: float) -> Growth:
        steady = self.steady(warmup, settle)
        last = self.points[-1].value if self.points else None
        if len(steady) < MIN_POINTS:
            return Growth(steady[0].value if steady else None, last, None, None)
        slope = pooled_slope(steady)
        middle = (steady[0].t + steady[-1].t) / 2
        first = [p.value for p in steady if p.t <= middle]
        second = [p.value for p in steady if p.t > middle]
        halves = max(second) - max(first) if first and second else None
        per_hour = None if slope is None else slope * HOUR / speedup
        return Growth(steady[0].value, last, per_hour, halves)


def pooled_slope(points: list[Point]) -> float | None:
    """The common slope (units per wall second) of a line per incarnation (pid) through
    `points`: sum((t - mean_t)(v - mean_v)) / sum((t - mean_t)^2) within each incarnation.
    None when no incarnation has two distinct times."""
    groups: dict[int, list[Point]] = defaultdict(list)
    for p in points:
        groups[p.pid].append(p)
    num = den = 0.0
    for group in groups.values():
        mean_t = sum(p.t for p in group) / len(group)
        mean_v = sum(p.value for p in group) / len(group)
        num += sum((p.t - mean_t) * (p.value - mean_v) for p in group)
        den += sum((p.t - mean_t) ** 2 for p in group)
    return num / den if den > 0 else None
