"""A robot's bid for a task, from its own state: where it is, its battery, its work.

Computed by the deciding thread from the state the RCL holds of the robot (what its
actor published, its link's telemetry), the whole fleet in one pass
(`fleet.FleetRound`). A bid says either how well the robot would do the task or
why it cannot take it now (`unfit`, a `WaitReason`):
- travel: the straight-line distance from its position to the task's place (0 without
  a place; unknown position: infinite), at its `cruise_speed`;
- battery: what is left after going there and then home (`base`), at `battery_per_km`;
  below its `battery_reserve` it cannot take the task (`battery`);
- its work: the highest priority among its open actions; a task of strictly higher
  priority pre-empts it (the resource rules then suspend that work), otherwise the
  robot is `busy`; a robot in teleop is `unavailable`.
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from typing import Any

from mrss.actors.rcl.allocation.profile import RobotProfile
from mrss.actors.rcl.allocation.task import Task
from mrss.links.geo import distance_m
from mrss.messages import WaitReason

Place = tuple[float, float]


@dataclass(frozen=True)
class BidRequest:
    """What one robot's bid is for: the task, the robot's profile, its home."""

    task: Task
    profile: RobotProfile
    base: Place | None  # home: declared, or where the robot was first seen


@dataclass(frozen=True)
class Work:
    """One open action of the bidding robot."""

    uuid: str
    priority: int
    done: float  # fraction done, from its progress (0 when it says nothing)


@dataclass(frozen=True)
class Bid:
    """What one robot offers for a task (all figures estimates, from its own state)."""

    robot: str
    finish_s: float = math.inf  # seconds until the task would be done (travel)
    travel_m: float = math.inf  # to the task's place
    home_m: float = 0.0  # from the task's place to its base
    back_m: float = 0.0  # from where it is now to its base (its way home without the task)
    battery: float | None = None  # % now (None: unknown)
    battery_after: float | None = None  # % after the task and the way home
    busy_priority: int | None = None  # the top priority of its open actions (None: idle)
    busy_done: float = 0.0  # how far that work is
    preempts: bool = False  # taking it suspends lower-priority work
    position: Place | None = None
    unfit: WaitReason = WaitReason.NONE
    note: str = ""  # why unfit, in words

    @property
    def fit(self) -> bool:
        return self.unfit is WaitReason.NONE

    @property
    def cost_m(self) -> float:
        """The distance the robot covers for the task: there, then home."""
        return self.travel_m + self.home_m

    @property
    def marginal_m(self) -> float:
        """What the task adds to the robot's way home from where it is."""
        return self.travel_m + self.home_m - self.back_m

    def describe(self) -> str:
        """"uav3: finish in 42 s, 71 % battery after" or "uav1 busy with priority 5"."""
        if not self.fit:
            return f"{self.robot} {self.note}"
        text = f"{self.robot}: finish in {_seconds(self.finish_s)}"
        if self.battery_after is not None:
            text += f", {self.battery_after:.0f} % battery after"
        if self.preempts:
            text += f", pre-empting priority {self.busy_priority}"
        return text


def no_bid(robot: str, reason: WaitReason, note: str) -> Bid:
    """A robot that cannot bid (unavailable, silent)."""
    return Bid(robot, unfit=reason, note=note)


def compute_bid(request: BidRequest, *, position: Place | None, battery: float | None,
                teleop: bool, work: Sequence[Work]) -> Bid:
    """The bid of `request.profile`'s robot for `request.task` from its state."""
    task, profile = request.task, request.profile
    robot = profile.robot
    if teleop:
        return Bid(robot, position=position, unfit=WaitReason.UNAVAILABLE, note="in teleop")
    top = max(work, key=lambda w: (w.priority, w.done), default=None)
    busy = top.priority if top is not None else None
    preempts = busy is not None and task.priority > busy
    if busy is not None and not preempts:
        return Bid(robot, position=position, busy_priority=busy, busy_done=top.done if top
                   else 0.0, unfit=WaitReason.BUSY,
                   note=f"busy with priority {busy} ({top.done:.0%} done)" if top else "busy")
    base = request.base or position
    travel, home, back, after = figures(task, profile, base, position, battery)
    if after is not None and after < profile.battery_reserve:
        return Bid(robot, travel_m=travel, home_m=home, back_m=back, battery=battery,
                   battery_after=after, busy_priority=busy, position=position,
                   unfit=WaitReason.BATTERY,
                   note=f"would have {after:.0f} % battery after, below its reserve "
                        f"{profile.battery_reserve:.0f} %")
    return Bid(robot, finish_s=travel / profile.cruise_speed, travel_m=travel, home_m=home,
               back_m=back, battery=battery, battery_after=after, busy_priority=busy,
               busy_done=top.done if top is not None else 0.0, preempts=preempts,
               position=position)


def figures(task: Task, profile: RobotProfile, base: Place | None, position: Place | None,
            battery: float | None, *, home_read: bool = True,
            back_read: bool = True) -> tuple[float, float, float, float | None]:
    """(travel_m, home_m, back_m, battery_after) of a robot for `task`: the figures of
    its bid, the same whether one bid is made (`compute_bid`) or a whole fleet is
    ranked in one pass (mrss.actors.rcl.allocation.fleet), which leaves out (0.0) the
    way home when neither its score (`home_read`) nor the battery needs it, and the way
    back unless its score reads it (`back_read`)."""
    home_read = home_read or battery is not None
    if task.near is None:
        travel = 0.0
        home = _dist(position, base) if position is not None and home_read else 0.0
    else:
        travel = _dist(position, task.near)
        home = _dist(task.near, base) if base is not None and home_read else 0.0
    back = _dist(position, base) if position is not None and base is not None \
        and back_read else 0.0
    after = None
    if battery is not None:
        after = battery - profile.battery_per_km * (travel + home) / 1000.0
    return travel, home, back, after


def link_state(link: Any) -> tuple[Place | None, float | None]:
    """(position, battery %) of a robot from its link: the last `position` and `battery`
    telemetry records (mrss.links.base.RobotLink.whereabouts, or `latest`), or
    `lat`/`lon`/`battery` attributes of a link of the project's own; None for what it
    does not say."""
    whereabouts = getattr(link, "whereabouts", None)
    if callable(whereabouts):
        found: tuple[Place | None, float | None] = whereabouts()
        return found
    latest = getattr(link, "latest", None)
    position = battery = None
    if callable(latest):
        p, b = latest("position"), latest("battery")
        if p and _number(p.get("lat")) and _number(p.get("lon")):
            position = (float(p["lat"]), float(p["lon"]))
        if b and _number(b.get("remaining")):
            battery = float(b["remaining"])
    else:
        lat: Any = getattr(link, "lat", None)
        lon: Any = getattr(link, "lon", None)
        if _number(lat) and _number(lon):
            position = (float(lat), float(lon))
        level: Any = getattr(link, "battery", None)
        if _number(level):
            battery = float(level)
    return position, battery


def fraction_done(progress: Mapping[str, Any]) -> float:
    """How far an action is, from a progress pair such as waypoint/waypoints (0: unknown)."""
    for key, value in progress.items():
        total: Any = progress.get(key + "s")
        if _number(value) and _number(total) and total > 0:
            return max(0.0, min(1.0, float(value) / float(total)))
    return 0.0


def _dist(a: Place | None, b: Place | None) -> float:
    if a is None or b is None:
        return math.inf
    return distance_m(a[0], a[1], b[0], b[1])


def _number(value: Any) -> bool:
    return isinstance(value, int | float) and not isinstance(value, bool) \
        and math.isfinite(value)


def _seconds(s: float) -> str:
    return "unknown time (position unknown)" if math.isinf(s) else f"{s:.0f} s"
