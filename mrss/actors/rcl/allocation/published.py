"""What the allocator publishes of a decision: a `TaskAllocation` with its bids.

An award or a wait goes out with the bids it was decided from, as plain figures and
enums (`mrss.messages.bid_reports`): the dashboard says why a robot won, or what a task
waits for, from them. The best `bid_reports.LIMIT` bids are listed, all are counted.
"""

from __future__ import annotations

from collections.abc import Mapping

from mrss.actors.rcl.allocation.bids import Bid
from mrss.actors.rcl.allocation.evaluators import Choice
from mrss.actors.rcl.allocation.profile import RobotProfile
from mrss.actors.rcl.allocation.task import Task
from mrss.messages import ActionRequest, AllocationState, TaskAllocation, WaitReason
from mrss.messages.bid_reports import LIMIT, BidReport, finite


def report(bid: Bid, profile: RobotProfile | None) -> BidReport:
    """`bid` as published (the robot's reserve from its profile)."""
    return BidReport(bid.robot, bid.unfit, finite(bid.finish_s), finite(bid.battery_after),
                     profile.battery_reserve if profile is not None else None,
                     bid.busy_priority, bid.busy_done, bid.preempts)


def allocation(request: ActionRequest, task: Task, choice: Choice, *, evaluator: str,
               profiles: Mapping[str, RobotProfile], lost_from: str = "") -> TaskAllocation:
    """The `TaskAllocation` of `choice` for `task`: awarded to its winner, or waiting."""
    winner = choice.winner
    return TaskAllocation(
        uuid=task.uuid,
        state=AllocationState.WAITING if winner is None else AllocationState.AWARDED,
        robot="" if winner is None else winner.robot,
        wait=choice.wait if winner is None else WaitReason.NONE,
        why=choice.why if not lost_from else f"reassigned from {lost_from} (lost): {choice.why}",
        name=request.name, goal=request.goal,
        bids=[report(b, profiles.get(b.robot)).to_wire() for b in choice.bids[:LIMIT]],
        bidders=choice.bidders, evaluator=evaluator,
        capabilities=sorted(task.capabilities),
        near=list(task.near) if task.near is not None else [],
        lost_from=lost_from if winner is not None else "")
