"""The goals an agent gives up for good, told to the operator (`GoalGaveUp` on the bus).

A goal is given up in one of three ways, each a `GiveUpReason`:

- `budget_exhausted`: the program's own retry loop used its budget up and says so with
  the action `give_up(Goal, budget_exhausted, Cause)` (the reasoner handles it, it never
  reaches the RCL; Cause is the last failure's `error(E)`);
- `plan_failed`: a plan failed and no `-!g` plan recovered it (the interpreter drops the
  intention), or the program says `give_up(Goal, plan_failed, Cause)` from the `-!g` plan
  that ends it;
- `no_applicable_plan`: no plan (or no applicable one) for the goal, and no `-!g` plan.

Each becomes one `GoalGaveUp` (agent, goal, reason, last cause, message), published on
`agent.gave_up.<agent>`, where the dashboard raises it as an alert, and one warning in
the log. A `give_up` whose reason is not of the set fails its plan with `error(rejected)`
and is logged: nothing is published on a misspelt reason.
"""

from __future__ import annotations

import logging
from collections.abc import Callable

from mrss.agentspeak import Struct
from mrss.agentspeak.goals import bare_text
from mrss.errors import MrssError
from mrss.messages import GiveUpReason, GoalGaveUp

log = logging.getLogger("mrss.reasoner")

GIVE_UP = "give_up"  # the action give_up(Goal, Reason, Cause)
GIVE_UP_ARITY = 3
NO_PLAN_ERRORS = frozenset({"no_applicable", "no_relevant"})


def is_give_up(action: Struct) -> bool:
    """Whether an environment action is the program's `give_up(Goal, Reason, Cause)`."""
    return action.functor == GIVE_UP and len(action.args) == GIVE_UP_ARITY


def of_action(agent: str, action: Struct) -> GoalGaveUp:
    """The alert of a `give_up(Goal, Reason, Cause)` action; MrssError for a reason
    outside the set."""
    goal, reason, cause = (bare_text(a) if isinstance(a, Struct) else str(a)
                           for a in action.args)
    try:
        member = GiveUpReason(reason)
    except ValueError:
        raise MrssError(f"give_up: unknown reason {reason!r} (one of "
                        f"{', '.join(GiveUpReason)})") from None
    return GoalGaveUp(agent=agent, goal=goal, reason=member, cause=cause,
                      message=f"given up by the program ({reason})")


def of_dropped(agent: str, goal: str, error: str | None, message: str) -> GoalGaveUp:
    """The alert of a goal whose failure no `-!g` plan handled."""
    reason = GiveUpReason.NO_APPLICABLE_PLAN if error in NO_PLAN_ERRORS \
        else GiveUpReason.PLAN_FAILED
    return GoalGaveUp(agent=agent, goal=goal, reason=reason, cause=error or "",
                      message=message)


class GiveUps:
    """Publishes every goal given up (`send`), and logs it; counts them (`sent`)."""

    def __init__(self, send: Callable[[GoalGaveUp], object] | None) -> None:
        self._send = send
        self.sent = 0

    def dropped_handler(self, agent: str) -> Callable[[str, str | None, str], None]:
        """The interpreter's `on_goal_dropped` for the agent named `agent`."""
        def dropped(goal: str, error: str | None, message: str) -> None:
            self.tell(of_dropped(agent, goal, error, message))
        return dropped

    def tell(self, alert: GoalGaveUp) -> None:
        log.warning("%s gave up goal %s: %s (last cause: %s) %s", alert.agent, alert.goal,
                    alert.reason.value, alert.cause or "none", alert.message)
        self.sent += 1
        if self._send is not None:
            try:
                self._send(alert)
            except Exception:  # the agent's cycle must go on: the log line is there
                log.exception("the alert of goal %s could not be published", alert.goal)
