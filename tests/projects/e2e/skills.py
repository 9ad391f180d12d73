"""Skills of the end-to-end test project (imported by its rcl.py)."""

from __future__ import annotations

from pathlib import Path

from mrss.api import Skill


class Travel(Skill):
    """Visit `count` waypoints, from the last one reached (progress `waypoint`).

    Each start appends the waypoint it starts from to progress `starts`, so the
    statuses show that a resumed action continues where it stopped.
    """

    def __init__(self, count: int) -> None:
        self.count = count

    def start(self) -> None:
        starts = list(self.progress.get("starts", []))  # type: ignore[call-overload]
        self.record_progress(starts=[*starts, int(self.progress.get("waypoint", 0))])  # type: ignore[arg-type]

    def run(self) -> bool:
        index = int(self.progress.get("waypoint", 0))  # type: ignore[arg-type]
        while index < self.count:
            if self.wait(self.link.leg):  # travelling; True when interrupted
                return False
            self.link.arrive(index)
            index += 1
            self.record_progress(waypoint=index)
        return True

    def terminate(self) -> None:
        self.link.stop()


class Survey(Travel):
    """Travel that needs the shared airspace (one survey at a time, by priority)."""

    resources = ("airspace",)


class Jam(Skill):
    """A skill whose robot fails: it raises, is restarted twice, then escalates."""

    max_restarts = 2
    restart_period = 60.0

    def run(self) -> None:
        raise RuntimeError(f"gearbox jammed on {self.robot}")


class Note(Skill):
    """An instant skill (reporting a result)."""

    def run(self) -> bool:
        self.link.notes += 1
        return True


class Gate(Skill):
    """Waits until its gate file exists (the test opens it): an action that ends exactly
    when the test wants, e.g. while the bus is down."""

    def __init__(self, gate: Path) -> None:
        self.gate = gate

    def run(self) -> bool:
        while not self.gate.exists():
            if self.wait(0.02):
                return False
        return True
