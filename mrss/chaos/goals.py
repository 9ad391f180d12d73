"""What became of each operator goal: the outcomes of the goal-handled invariant (pure).

An accepted goal (the broker acknowledged its publish) ends SUCCEEDED if an action for
it succeeded, REPORTED if a message on a reply topic names it or the agent's final mind
says it failed (a belief of the project's `[operator.goals] failed` pattern naming it:
the operator's dashboard shows that goal as failed), CANCELLED if the operator
cancelled it, IN_PROGRESS if an action for it is open at the end, HELD if the agent's
final mind has a belief of the project's `pending_beliefs` naming it, else DROPPED.
Nothing holds a goal, nor says it failed, unless the project declares which beliefs do
(chaos.py's `PENDING_BELIEFS`, `[operator.goals] failed`): a belief that merely names
the goal (`refused(a1, rule)`, `failed_goal(a1)`) is not a promise to pursue it.
Actions and cancels count for a goal from its publish until the goal is sent again.
"""

from __future__ import annotations

import json
import re
from enum import StrEnum
from typing import Any

from mrss.chaos.history import History
from mrss.chaos.views import TERMINAL, accepted, last_mind, requests
from mrss.chaos.views import actions as known_actions
from mrss.messages import EventStatus


class GoalOutcome(StrEnum):
    SUCCEEDED = "succeeded"
    REPORTED = "reported failed"
    CANCELLED = "cancelled by the operator"
    IN_PROGRESS = "in progress"
    HELD = "held by the agent"
    DROPPED = "dropped"


def goal_outcomes(h: History) -> tuple[dict[str, GoalOutcome], set[str]]:
    """Each accepted operator goal's outcome, and the goals some action was requested for."""
    actions = known_actions(h)  # with those compacted away, as the bus showed them
    reqs = list(requests(h).values())
    outcomes: dict[str, GoalOutcome] = {}
    acted: set[str] = set()
    goals = accepted(h, "goal")
    pending = tuple(str(p) for p in h.campaign.get("pending_beliefs", ()))
    failed = tuple(str(p) for p in h.campaign.get("failed_beliefs", ()))
    mind = last_mind(h)
    for i, step in enumerate(goals):
        later = [g.t for g in goals[i + 1:] if g.goal == step.goal]
        until = min(later, default=float("inf"))
        mine = [a for a in actions if a.goal == step.goal and step.t <= a.created < until]
        if mine or any(r.body.get("goal") == step.goal and step.t <= r.t < until
                       for r in reqs):
            acted.add(step.goal)
        if any(a.state == "succeeded" for a in mine):
            outcome = GoalOutcome.SUCCEEDED
        elif any(_names_goal(r.payload, step.goal) for r in h.replies if r.t >= step.t) \
                or (mind is not None and _held(mind, step.goal, failed)):
            outcome = GoalOutcome.REPORTED
        elif any(c.goal == step.goal and step.t <= c.t < until
                 for c in accepted(h, "cancel")):
            outcome = GoalOutcome.CANCELLED
        elif any(a.state not in TERMINAL for a in mine):
            outcome = GoalOutcome.IN_PROGRESS
        elif mind is not None and _held(mind, step.goal, pending):
            outcome = GoalOutcome.HELD
        else:
            outcome = GoalOutcome.DROPPED
        outcomes[step.goal] = outcome
    return outcomes, acted


NOT_AN_OUTCOME = (EventStatus.ACCEPTED.value, EventStatus.DUPLICATE.value)


def _names_goal(payload: str, goal: str) -> bool:
    """Whether a reply tells the operator what became of `goal`: an answer that only
    says the event was accepted (or seen twice) does not."""
    try:
        obj = json.loads(payload)
    except ValueError:
        obj = None
    if isinstance(obj, dict):
        if obj.get("status") in NOT_AN_OUTCOME:
            return False
        if obj.get("goal") == goal:
            return True
    return f'"{goal}"' in payload


def _held(mind: dict[str, Any], goal: str, functors: tuple[str, ...]) -> bool:
    """Whether a belief of one of `functors` names `goal` (never, without functors)."""
    if not functors:
        return False
    arg = re.compile(rf"[(,]{re.escape(goal)}[,)]")
    starts = tuple(f"{f}(" for f in functors)
    return any(text.startswith(starts) and arg.search(text)
               for text in mind.get("beliefs", []))
