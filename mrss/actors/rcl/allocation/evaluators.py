"""How the bids for a task are ranked: named evaluators, a project's own, one tie-break.

An evaluator scores a fit bid (lower wins):
- `quickest_finish` (default): the seconds until the task would be done;
- `least_cost`: the distance the robot covers for it, there and home;
- `least_marginal_cost`: what it adds to the robot's way home from where it is;
- `battery_aware`: the most battery left after it (unknown battery ranks last).
A project's own is a function `score(task, bid) -> float` (`RobotCommLayer.bid_score`);
one that raises or returns no finite number is replaced by the default for that round,
logged once per kind of fault and interval.

The rank of a bid: fit before unfit; a robot that would not pre-empt other work before
one that would; the score; then the robot id, so equal bids always go to the same robot.
"""

from __future__ import annotations

import logging
import math
from collections.abc import Callable, Collection, Sequence
from dataclasses import dataclass
from enum import StrEnum

from mrss.actors.rcl.allocation.bids import Bid
from mrss.actors.rcl.allocation.task import Task
from mrss.edge.rejections import RejectionLog
from mrss.messages import WaitReason
from mrss.messages.bid_reports import LIMIT

log = logging.getLogger("mrss.rcl.allocation")

BidScore = Callable[[Task, Bid], float]
#: A named evaluator's score from a fit bid's figures: (finish_s, travel_m, home_m,
#: back_m, battery_after) -> lower wins (the fleet's round scores without making a Bid).
FigureScore = Callable[[float, float, float, float, float | None], float]


class Evaluator(StrEnum):
    """The named ways of ranking bids (the RCL option `evaluator`)."""

    QUICKEST_FINISH = "quickest_finish"
    LEAST_COST = "least_cost"
    LEAST_MARGINAL_COST = "least_marginal_cost"
    BATTERY_AWARE = "battery_aware"


FIGURE_SCORES: dict[Evaluator, FigureScore] = {
    Evaluator.QUICKEST_FINISH: lambda finish, _t, _h, _b, _a: finish,
    Evaluator.LEAST_COST: lambda _f, travel, home, _b, _a: travel + home,  # Bid.cost_m
    Evaluator.LEAST_MARGINAL_COST: lambda _f, travel, home, back, _a: travel + home - back,
    Evaluator.BATTERY_AWARE: lambda _f, _t, _h, _b, after: -after if after is not None
    else math.inf,
}

#: The figures besides travel and battery_after each named evaluator's score reads:
#: (home_m, back_m); a round over the fleet computes no other.
READS: dict[Evaluator, tuple[bool, bool]] = {
    Evaluator.QUICKEST_FINISH: (False, False),
    Evaluator.LEAST_COST: (True, False),
    Evaluator.LEAST_MARGINAL_COST: (True, True),
    Evaluator.BATTERY_AWARE: (False, False),
}


#: The named evaluators whose score reads battery_after.
READS_BATTERY = frozenset({Evaluator.BATTERY_AWARE})


def _bid_score(figures: FigureScore) -> BidScore:
    return lambda _t, b: figures(b.finish_s, b.travel_m, b.home_m, b.back_m, b.battery_after)


SCORES: dict[Evaluator, BidScore] = {e: _bid_score(f) for e, f in FIGURE_SCORES.items()}
DEFAULT = Evaluator.QUICKEST_FINISH

#: How many bids after the winner an award's reason names.
SHOWN = 3
#: How many unfit bids a waiting task's reason names.
WAITING_SHOWN = 4
#: The excuses of unfit robots, the one a waiting task reports first.
WAIT_ORDER = (WaitReason.BUSY, WaitReason.BATTERY, WaitReason.UNAVAILABLE, WaitReason.NO_BID)


@dataclass(frozen=True)
class Choice:
    """The decision of one round: the winner (None: the task waits, and why)."""

    winner: Bid | None
    wait: WaitReason
    why: str
    bids: tuple[Bid, ...] = ()  # the best (at most LIMIT) in rank order, the winner first
    bidders: int = 0  # how many robots bid, all counted


class BidRanking:
    """Ranks bids with one evaluator (named or a project's function), falling back to
    the default when a project's function misbehaves."""

    def __init__(self, evaluator: Evaluator | BidScore = DEFAULT) -> None:
        self.evaluator = evaluator
        self.faults = RejectionLog(log, "bid evaluator")

    @property
    def name(self) -> str:
        e = self.evaluator
        return e.value if isinstance(e, Evaluator) else getattr(e, "__name__", repr(e))

    @property
    def figure_score(self) -> FigureScore | None:
        """The named evaluator's score from figures (None: a project's own, which is
        given whole bids)."""
        e = self.evaluator
        return FIGURE_SCORES[e] if isinstance(e, Evaluator) else None

    @property
    def reads(self) -> tuple[bool, bool]:
        """(home_m, back_m): whether the score reads them (a project's own: both)."""
        e = self.evaluator
        return READS[e] if isinstance(e, Evaluator) else (True, True)

    @property
    def reads_battery(self) -> bool:
        """Whether the score reads battery_after (a project's own: yes)."""
        e = self.evaluator
        return e in READS_BATTERY if isinstance(e, Evaluator) else True

    def choose(self, task: Task, bids: Sequence[Bid]) -> Choice:
        """The winner among `bids` (deterministic), or why the task waits."""
        fit = [b for b in bids if b.fit]
        if not fit:
            return _waiting(bids)
        scores = self._scores(task, fit)
        ranked = sorted(zip(fit, scores, strict=True),
                        key=lambda bs: (bs[0].preempts, bs[1], bs[0].robot))
        others = [b for b, _ in ranked[1:]] + sorted((b for b in bids if not b.fit),
                                                     key=lambda b: b.robot)
        return self.award(ranked[0][0], others, len(others))

    def award(self, winner: Bid, shown: Sequence[Bid], others: int) -> Choice:
        """The choice of `winner` over `others` more bids, of which `shown` are the best
        in rank order (at least SHOWN of them when there are; the choice keeps at most
        LIMIT bids): why in words names it, the first SHOWN, and how many more."""
        why = winner.describe()
        if shown:
            why += "; " + "; ".join(b.describe() for b in shown[:SHOWN])
            if others > SHOWN:
                why += f"; {others - SHOWN} more"
        return Choice(winner, WaitReason.NONE, f"{why} ({self.name})",
                      (winner, *shown[:LIMIT - 1]), others + 1)

    def _scores(self, task: Task, fit: Sequence[Bid]) -> list[float]:
        score = SCORES[self.evaluator] if isinstance(self.evaluator, Evaluator) \
            else self.evaluator
        try:
            values = [score(task, b) for b in fit]
            bad = [v for v in values if isinstance(v, bool)
                   or not isinstance(v, int | float) or math.isnan(v)]
            if not bad:
                return [float(v) for v in values]
            self.faults.reject(self.name, "returned no number",
                               f"{self.name} returned {bad[0]!r} for {task.uuid}; "
                               f"{DEFAULT.value} decides instead")
        except Exception as exc:
            self.faults.reject(self.name, f"raised {type(exc).__name__}",
                               f"{self.name} raised {exc!r} for {task.uuid}; "
                               f"{DEFAULT.value} decides instead")
        return [SCORES[DEFAULT](task, b) for b in fit]


def _waiting(bids: Sequence[Bid]) -> Choice:
    ordered = sorted(bids, key=lambda b: (wait_rank(b.unfit), b.robot))
    return waiting({b.unfit for b in bids}, ordered[:LIMIT], len(bids))


def wait_rank(reason: WaitReason) -> int:
    """Where an excuse comes in a waiting task's reason (WAIT_ORDER; others last)."""
    return WAIT_ORDER.index(reason) if reason in WAIT_ORDER else len(WAIT_ORDER)


def waiting(excuses: Collection[WaitReason], shown: Sequence[Bid], total: int) -> Choice:
    """Why a task waits: the first excuse of WAIT_ORDER among `excuses`, and the first
    WAITING_SHOWN of the `total` unfit bids (`shown`: the best, at least that many when
    there are, best excuse then robot id first; the choice keeps at most LIMIT)."""
    reason = next((r for r in WAIT_ORDER if r in excuses), WaitReason.NO_BID)
    why = "; ".join(b.describe() for b in shown[:WAITING_SHOWN])
    if total > WAITING_SHOWN:
        why += f"; {total - WAITING_SHOWN} more"
    return Choice(None, reason, why or "no robot answered", tuple(shown[:LIMIT]), total)
