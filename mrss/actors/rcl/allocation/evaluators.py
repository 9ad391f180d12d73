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
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from enum import StrEnum

from mrss.actors.rcl.allocation.bids import Bid
from mrss.actors.rcl.allocation.task import Task
from mrss.edge.rejections import RejectionLog
from mrss.messages import WaitReason

log = logging.getLogger("mrss.rcl.allocation")

BidScore = Callable[[Task, Bid], float]


class Evaluator(StrEnum):
    """The named ways of ranking bids (the RCL option `evaluator`)."""

    QUICKEST_FINISH = "quickest_finish"
    LEAST_COST = "least_cost"
    LEAST_MARGINAL_COST = "least_marginal_cost"
    BATTERY_AWARE = "battery_aware"


SCORES: dict[Evaluator, BidScore] = {
    Evaluator.QUICKEST_FINISH: lambda _t, b: b.finish_s,
    Evaluator.LEAST_COST: lambda _t, b: b.cost_m,
    Evaluator.LEAST_MARGINAL_COST: lambda _t, b: b.marginal_m,
    Evaluator.BATTERY_AWARE: lambda _t, b: -b.battery_after if b.battery_after is not None
    else math.inf,
}
DEFAULT = Evaluator.QUICKEST_FINISH

#: The excuses of unfit robots, the one a waiting task reports first.
WAIT_ORDER = (WaitReason.BUSY, WaitReason.BATTERY, WaitReason.UNAVAILABLE, WaitReason.NO_BID)


@dataclass(frozen=True)
class Choice:
    """The decision of one round: the winner (None: the task waits, and why)."""

    winner: Bid | None
    wait: WaitReason
    why: str
    bids: tuple[Bid, ...] = ()  # in rank order (the winner first), as `why` lists them


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

    def choose(self, task: Task, bids: Sequence[Bid]) -> Choice:
        """The winner among `bids` (deterministic), or why the task waits."""
        fit = [b for b in bids if b.fit]
        if not fit:
            return _waiting(bids)
        scores = self._scores(task, fit)
        ranked = sorted(zip(fit, scores, strict=True),
                        key=lambda bs: (bs[0].preempts, bs[1], bs[0].robot))
        winner = ranked[0][0]
        others = [b for b, _ in ranked[1:]] + sorted((b for b in bids if not b.fit),
                                                     key=lambda b: b.robot)
        why = winner.describe()
        if others:
            why += "; " + "; ".join(b.describe() for b in others[:3])
            if len(others) > 3:
                why += f"; {len(others) - 3} more"
        return Choice(winner, WaitReason.NONE, f"{why} ({self.name})", (winner, *others))

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
    excuses = {b.unfit for b in bids}
    reason = next((r for r in WAIT_ORDER if r in excuses), WaitReason.NO_BID)
    ordered = sorted(bids, key=lambda b: (WAIT_ORDER.index(b.unfit)
                                          if b.unfit in WAIT_ORDER else 9, b.robot))
    why = "; ".join(b.describe() for b in ordered[:4])
    if len(ordered) > 4:
        why += f"; {len(ordered) - 4} more"
    return Choice(None, reason, why or "no robot answered", tuple(ordered))
