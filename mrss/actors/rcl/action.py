"""The environment action as the RCL tracks it (private home; projects import `mrss.api`).

`Action` is one request of the agent on its way through the RCL: its robot, goal,
priority, state (moved only through the lifecycle's transition table), progress and the
reason and cause of its end. `check_json` is the RCL's own test that a value can go into
the journal and on the bus; it is not part of the contract (docs/rcl.md, "Actions").
"""

from __future__ import annotations

import dataclasses
import json
from dataclasses import dataclass, field
from typing import Any

from mrss.actors.rcl.lifecycle import check_action_transition
from mrss.errors import ActionError
from mrss.messages import ActionState, JsonValue


def check_json(value: Any, what: str) -> None:
    """Raise ActionError unless `value` can go into the journal and on the bus."""
    try:
        json.dumps(value)
    except (TypeError, ValueError) as exc:
        raise ActionError(f"{what} is not JSON-compatible: {exc}") from None


@dataclass
class Action:
    """An environment action of the agent, as the RCL tracks it."""

    uuid: str
    name: str
    args: list[JsonValue] = field(default_factory=list)
    robot: str = ""
    goal: str = ""
    priority: int = 0
    state: ActionState = ActionState.PENDING
    progress: dict[str, JsonValue] = field(default_factory=dict)
    literal: str = ""
    reason: str = ""
    cause: str = ""  # a FailureCause value once failed for a known cause, else ""
    # A skill's open critical section (Skill.critical): its name, bound, and whether a
    # stop waits for it. Published with the status, never journaled (a restart ends it).
    critical: str = ""
    critical_bound: float = 0.0
    deferring: bool = False
    # The longest its skills go without news (`progress_bound_of` its skills), seconds;
    # 0: no promise. Published with the status, never journaled (set again on each run).
    progress_bound: float = 0.0

    @property
    def terminal(self) -> bool:
        return self.state.terminal

    def transition(self, new: ActionState, reason: str = "", cause: str = "") -> None:
        """Move to `new` (ActionError if the table forbids it) and record why."""
        check_action_transition(self.state, new, self.uuid)
        self.state = new
        self.reason = reason
        self.cause = cause

    def copy(self) -> Action:
        """An independent snapshot (args and progress copied)."""
        return dataclasses.replace(self, args=list(self.args), progress=dict(self.progress))
