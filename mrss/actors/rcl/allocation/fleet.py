"""Every capable robot's bid for a task in one pass over the fleet's state: one round.

A round reads what it bids from once (`FleetRound`): which robots are unavailable and
why (one read under the core's lock), what every robot actor published (the bid board,
one read under its lock), and each robot's position and battery from its link, read at
most once per round. Then, for a named evaluator, each capable robot is scored from its
figures (`bids.figures`, the numbers `compute_bid` makes a `Bid` of) without making a
`Bid`: only the best few (`bid_reports.LIMIT`, what the award publishes and its reason
names) are made whole (`compute_bid`, so they say what a single bid would). A score
that reads neither the way home nor the battery (quickest_finish) ranks without them:
the battery after the way home is checked in rank order, only until the best few fit
ones are found (every robot is counted all the same). The
ranking is the one of `evaluators.BidRanking.choose` (idle before pre-empting, the
score, the robot id), so both give the same choice. The general path
(`BidRanking.choose` over every bid) is taken for a project's own evaluator (it is
given whole bids) and when a score is not a number (the ranking falls back to the
default, logged). A task no robot is fit for
waits with the best excuse, the first few robots' bids named.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Mapping, Sequence

from mrss.actors.rcl.allocation.bids import Bid, BidRequest, Place, compute_bid, figures, no_bid
from mrss.actors.rcl.allocation.board import BidState
from mrss.actors.rcl.allocation.evaluators import (
    BidRanking,
    Choice,
    wait_rank,
    waiting,
)
from mrss.actors.rcl.allocation.profile import RobotProfile
from mrss.actors.rcl.allocation.task import Task
from mrss.messages import WaitReason
from mrss.messages.bid_reports import LIMIT

Where = Callable[[str], tuple[Place | None, float | None]]


class FleetRound:
    """The fleet's state as one round reads it, and its choice for each open task."""

    def __init__(self, unavailable: Mapping[str, str], states: Mapping[str, BidState],
                 where: Where, bases: dict[str, Place]) -> None:
        self.unavailable, self.states = unavailable, states
        self._where = where
        self._bases = bases  # first-seen positions of robots without a base (kept here)
        self._seen: dict[str, tuple[Place | None, float | None]] = {}

    def where(self, robot: str) -> tuple[Place | None, float | None]:
        """(position, battery) of `robot`, read from its link once per round."""
        seen = self._seen.get(robot)
        if seen is None:
            seen = self._seen[robot] = self._where(robot)
            if seen[0] is not None and robot not in self._bases:
                self._bases[robot] = seen[0]
        return seen

    def base(self, profile: RobotProfile) -> Place | None:
        return profile.base or self._bases.get(profile.robot)

    def bid(self, task: Task, profile: RobotProfile) -> Bid:
        """One robot's whole bid (what the award's reason and a waiting task show)."""
        robot = profile.robot
        refusal = self.unavailable.get(robot)
        state = self.states.get(robot)
        if refusal is not None or state is None:
            return no_bid(robot, WaitReason.UNAVAILABLE,
                          f"unavailable: {refusal or 'its actor is down'}")
        position, battery = self.where(robot)
        return compute_bid(BidRequest(task, profile, self.base(profile)), position=position,
                           battery=battery, teleop=state.teleop, work=state.work)

    def choose(self, task: Task, capable: Sequence[RobotProfile],
               ranking: BidRanking) -> Choice:
        """The winner among the `capable` robots' bids for `task`, or why it waits."""
        score = ranking.figure_score
        if score is None:
            return ranking.choose(task, [self.bid(task, p) for p in capable])
        # (pre-empts, score, robot, its profile, its battery to check): rank order (robot
        # ids are unique)
        ranked: list[tuple[bool, float, str, RobotProfile, float | None]] = []
        unfit: list[tuple[WaitReason, str, RobotProfile]] = []
        priority = task.priority
        home_read, back_read = ranking.reads
        # A score that reads neither the way home nor the battery ranks without them: the
        # battery is checked (the way home measured) in rank order, for the robots that
        # could be named only
        later = not home_read and not ranking.reads_battery
        for profile in capable:
            robot = profile.robot
            state = self.states.get(robot)
            if state is None or state.teleop or robot in self.unavailable:
                unfit.append((WaitReason.UNAVAILABLE, robot, profile))
                continue
            top = state.top
            if top is not None and priority <= top.priority:
                unfit.append((WaitReason.BUSY, robot, profile))  # its work goes first
                continue
            position, battery = self.where(robot)
            deferred = battery if later else None
            travel, home, back, after = figures(task, profile, self.base(profile) or position,
                                                position, None if later else battery,
                                                home_read=home_read, back_read=back_read)
            if after is not None and after < profile.battery_reserve:
                unfit.append((WaitReason.BATTERY, robot, profile))
                continue
            value = score(travel / profile.cruise_speed, travel, home, back, after)
            if math.isnan(value):  # the ranking's fallback decides, as for any bad score
                return ranking.choose(task, [self.bid(task, p) for p in capable])
            ranked.append((top is not None, value, robot, profile, deferred))
        ranked.sort(key=lambda f: f[:3])
        named: list[RobotProfile] = []  # the best fit ones, in rank order
        for _, _, robot, profile, battery in ranked:
            if battery is not None and self._short(task, profile, battery):
                unfit.append((WaitReason.BATTERY, robot, profile))
                continue
            named.append(profile)
            if len(named) == LIMIT:
                break  # every robot is counted; the rest need not be named
        if not named:  # every robot ranked was checked: `unfit` has them all
            unfit.sort(key=lambda u: (wait_rank(u[0]), u[1]))
            return waiting({reason for reason, _, _ in unfit},
                           [self.bid(task, p) for _, _, p in unfit[:LIMIT]], len(unfit))
        if len(named) < LIMIT:  # after the fit ones, the unfit ones by robot id (all known)
            named += [p for _, _, p in sorted(unfit, key=lambda u: u[1])][:LIMIT - len(named)]
        bids = [self.bid(task, p) for p in named]
        return ranking.award(bids[0], bids[1:], len(capable) - 1)  # every robot bid

    def _short(self, task: Task, profile: RobotProfile, battery: float) -> bool:
        """Whether the robot would come home below its reserve (its figures as a bid's)."""
        position = self.where(profile.robot)[0]
        after = figures(task, profile, self.base(profile) or position, position, battery,
                        home_read=True, back_read=False)[3]
        return after is not None and after < profile.battery_reserve
