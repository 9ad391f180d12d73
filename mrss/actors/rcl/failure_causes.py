"""The FailureCause of an exception raised by project code (a skill, `refine_action`).

What the agent sees as `error(Cause)` when a skill or the refinement raises:

- `TransientError` (the data layer's "no reply in time" is one): `transient`, a
  dependency was away and another try may work;
- `LinkDown` (the link found the robot unreachable): `link_down`, as when the RCL hears
  the link go down first. Which of the two notices a lost robot first is a race (a
  skill waiting on telemetry often wins it), and the agent must see the same cause;
- `CommandTimeout` (the robot did not answer, or finish, a command after all retries):
  `transient`. A robot silent for a moment (out of radio range, its autopilot
  restarting) looks exactly like this before its link is declared down;
- anything else (`CommandRejected`, a bug in the project): "" (`action_failed`), the
  robot refused or the project failed, and another try would do the same.
"""

from __future__ import annotations

from mrss.errors import TransientError
from mrss.links.errors import CommandTimeout, LinkDown
from mrss.messages import FailureCause


def failure_cause(exc: BaseException) -> str:
    """The FailureCause value for `exc` ("" when it has none: `action_failed`)."""
    if isinstance(exc, LinkDown):
        return FailureCause.LINK_DOWN.value
    if isinstance(exc, TransientError | CommandTimeout):
        return FailureCause.TRANSIENT.value
    return ""
