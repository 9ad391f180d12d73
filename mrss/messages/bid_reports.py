"""The bids behind an allocation decision, as `TaskAllocation.bids` carries them.

The allocator publishes, with each award and each wait, the bids it decided from: one
map per robot, in rank order (the winner first; for a waiting task the robots with the
best excuse first), each the plain figures of a bid and its excuse as a `WaitReason`,
never words. Readers (the dashboard, `mrss incident`) make their own sentences from
them (`BidReport.describe`), so "uav3: finish in 42 s, 71 % battery after; uav1 busy
with priority 5" is derived from what the robots bid, not parsed back out of prose.

A report's keys (`FIELDS`): `robot`; `unfit` (a `WaitReason` value, "" for a fit bid);
`finish_s` (seconds to finish, None unknown), `battery_after` (% after the task and the
way home, None unknown), `reserve` (% the robot keeps to get home, None unknown),
`busy_priority` (the top priority of its open work, None idle), `busy_done` (how far
that work is, 0..1) and `preempts` (taking the task suspends that work).
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any

from mrss.errors import DecodeError
from mrss.messages.closed_sets import WaitReason

FIELDS = ("robot", "unfit", "finish_s", "battery_after", "reserve", "busy_priority",
          "busy_done", "preempts")
LIMIT = 16  # reports per message: the best ones; a fleet's tail is counted, not listed


@dataclass(frozen=True)
class BidReport:
    """One robot's bid as published (see the module docstring for each field)."""

    robot: str
    unfit: WaitReason = WaitReason.NONE
    finish_s: float | None = None
    battery_after: float | None = None
    reserve: float | None = None
    busy_priority: int | None = None
    busy_done: float = 0.0
    preempts: bool = False

    @property
    def fit(self) -> bool:
        return self.unfit is WaitReason.NONE

    def to_wire(self) -> dict[str, Any]:
        return {"robot": self.robot, "unfit": self.unfit.value, "finish_s": self.finish_s,
                "battery_after": self.battery_after, "reserve": self.reserve,
                "busy_priority": self.busy_priority, "busy_done": self.busy_done,
                "preempts": self.preempts}

    @classmethod
    def from_wire(cls, data: dict[str, Any]) -> BidReport:
        """From a checked map (`check`): missing keys take their defaults."""
        return cls(str(data["robot"]), WaitReason(data.get("unfit", "")),
                   data.get("finish_s"), data.get("battery_after"), data.get("reserve"),
                   data.get("busy_priority"), float(data.get("busy_done") or 0.0),
                   bool(data.get("preempts", False)))

    def describe(self, unavailable: str = "") -> str:
        """"uav3: finish in 42 s, 71 % battery after", "uav1 busy with priority 5 (40 %
        done)"; `unavailable` says why an unavailable robot is (its robot state's reason)."""
        if self.unfit is WaitReason.BUSY:
            done = f" ({self.busy_done:.0%} done)" if self.busy_done else ""
            return f"{self.robot} busy with priority {self.busy_priority}{done}"
        if self.unfit is WaitReason.BATTERY:
            after = "" if self.battery_after is None else f" ({self.battery_after:.0f} %"
            reserve = "" if self.reserve is None else f" < reserve {self.reserve:.0f} %"
            return f"{self.robot} battery too low{after}{reserve}{')' if after else ''}"
        if self.unfit is WaitReason.UNAVAILABLE:
            return f"{self.robot} unavailable" + (f": {unavailable}" if unavailable else "")
        if self.unfit is WaitReason.NO_BID:
            return f"{self.robot} did not bid"
        finish = "unknown time" if self.finish_s is None else f"{self.finish_s:.0f} s"
        text = f"{self.robot}: finish in {finish}"
        if self.battery_after is not None:
            text += f", {self.battery_after:.0f} % battery after"
        if self.preempts:
            text += f", pre-empting priority {self.busy_priority}"
        return text


def finite(value: float | None) -> float | None:
    """A figure for the wire: None for unknown (an infinite estimate)."""
    return None if value is None or not math.isfinite(value) else float(value)


_NUMBER = (int, float)


def check(reports: list[Any]) -> None:
    """DecodeError naming the report and key of anything that is not a bid report."""
    if len(reports) > LIMIT:
        raise DecodeError(f"{len(reports)} bid reports, at most {LIMIT}")
    for i, report in enumerate(reports):
        if not isinstance(report, dict):
            raise DecodeError(f"bid report {i} is not a map")
        unknown = sorted(set(report) - set(FIELDS))
        if unknown:
            raise DecodeError(f"bid report {i} has unknown key(s) {unknown}")
        if not isinstance(report.get("robot"), str) or not report["robot"]:
            raise DecodeError(f"bid report {i} names no robot")
        if report.get("unfit", "") not in WaitReason._value2member_map_:
            raise DecodeError(f"bid report {i}: unknown excuse {report.get('unfit')!r} "
                              f"(one of {', '.join(repr(w.value) for w in WaitReason)})")
        for key in ("finish_s", "battery_after", "reserve", "busy_done"):
            value = report.get(key)
            if value is not None and (isinstance(value, bool) or not isinstance(value, _NUMBER)):
                raise DecodeError(f"bid report {i}: {key} is not a number")
        busy = report.get("busy_priority")
        if busy is not None and (isinstance(busy, bool) or not isinstance(busy, int)):
            raise DecodeError(f"bid report {i}: busy_priority is not an integer")
        if not isinstance(report.get("preempts", False), bool):
            raise DecodeError(f"bid report {i}: preempts is not true or false")
