"""A robot's failsafe: what it does on its own when it loses its controller, and when.

Rules, in one place:
- A robot's table may declare ``failsafe = "hold" | "rtl" | "stop"`` and
  ``failsafe_timeout = SECONDS`` (wall-clock, 2..120, default 5 — ArduPilot's range and
  default of FS_GCS_TIMEOUT). Without ``failsafe`` the link leaves the robot's own setting
  alone; a ``failsafe_timeout`` without a ``failsafe`` is an error.
- The controller is the link: it sends the robot a heartbeat at 1 Hz while a live robot
  actor controls the robot (`RobotLink.watch_controller`). A robot that has heard one
  and then hears none for the timeout goes to its safe state and stays there until
  commanded again: HOLD stops where it is (copter: BRAKE), RTL goes home (copter: RTL,
  ground robot: back to base), STOP ends all motion (copter: LAND).
- When the link learns that the robot went to its failsafe, it reports the robot down
  with a reason of cause FAILSAFE (``"failsafe: ..."``), even if it was down already,
  and up again once the robot hears it: whatever the RCL was doing on that robot was
  overtaken by the robot itself, so running actions end with that reason.
"""

from __future__ import annotations

import difflib
from collections.abc import Mapping
from dataclasses import dataclass
from enum import StrEnum
from typing import Any

from mrss.errors import ConfigError

FAILSAFE_KEY = "failsafe"
TIMEOUT_KEY = "failsafe_timeout"
DEFAULT_TIMEOUT_S = 5.0
MIN_TIMEOUT_S = 2.0
MAX_TIMEOUT_S = 120.0
CONTROLLER_HEARTBEAT_S = 1.0  # how often a link tells its robot that it is still there


class FailsafeAction(StrEnum):
    """The safe state a robot goes to when it loses its controller."""

    HOLD = "hold"
    RTL = "rtl"
    STOP = "stop"


class LinkDownCause(StrEnum):
    """Why a link reports its robot down: unreachable, or it took over (failsafe)."""

    UNREACHABLE = "unreachable"
    FAILSAFE = "failsafe"


class FailsafeEvent(StrEnum):
    """What a link's ``failsafe`` telemetry record reports."""

    CONFIGURED = "configured"          # the robot confirmed the declared failsafe
    NOT_CONFIGURED = "not_configured"  # it did not: it keeps its own setting
    TRIGGERED = "triggered"            # it lost its controller and took its failsafe
    REGAINED = "regained"              # it hears its controller again (stays put until commanded)


@dataclass(frozen=True)
class FailsafePolicy:
    """A robot's declared failsafe: the action and the silence that triggers it."""

    action: FailsafeAction
    timeout_s: float = DEFAULT_TIMEOUT_S

    def describe(self) -> str:
        return f"{self.action.value} after {self.timeout_s:g} s without its controller"


def parse_action(value: Any, *, key: str = FAILSAFE_KEY, source: str | None = None
                 ) -> FailsafeAction:
    """The FailsafeAction named by `value`; ConfigError naming `key` (with a suggestion)."""
    known = [a.value for a in FailsafeAction]
    if isinstance(value, FailsafeAction):
        return value
    if not isinstance(value, str):
        raise ConfigError(f"must be one of {', '.join(known)}, not {value!r}",
                          file=source, key=key)
    try:
        return FailsafeAction(value.strip().lower())
    except ValueError:
        close = difflib.get_close_matches(value.strip().lower(), known, n=1, cutoff=0.5)
        hint = f"; did you mean {close[0]!r}?" if close else ""
        raise ConfigError(f"unknown failsafe {value!r} (known: {', '.join(known)}){hint}",
                          file=source, key=key) from None


def parse_timeout(value: Any, *, key: str = TIMEOUT_KEY, source: str | None = None) -> float:
    """Seconds in [2, 120]; ConfigError naming `key` otherwise."""
    if isinstance(value, bool) or not isinstance(value, int | float) \
            or not MIN_TIMEOUT_S <= value <= MAX_TIMEOUT_S:
        raise ConfigError(f"must be seconds between {MIN_TIMEOUT_S:g} and {MAX_TIMEOUT_S:g}, "
                          f"not {value!r}", file=source, key=key)
    return float(value)


def parse_policy(action: Any, timeout: Any = None, *, source: str | None = None,
                 keys: tuple[str, str] = (FAILSAFE_KEY, TIMEOUT_KEY)) -> FailsafePolicy | None:
    """The policy of `failsafe` / `failsafe_timeout` values (None: none declared).

    `keys` names the two settings in errors (e.g. "components.rcl.robots.uav1.failsafe",
    or a command line's "--failsafe").
    """
    action_key, timeout_key = keys
    if action is None:
        if timeout is not None:
            raise ConfigError(f"needs {action_key} = "
                              f"{' | '.join(repr(a.value) for a in FailsafeAction)} too",
                              file=source, key=timeout_key)
        return None
    chosen = parse_action(action, key=action_key, source=source)
    if timeout is None:
        return FailsafePolicy(chosen)
    return FailsafePolicy(chosen, parse_timeout(timeout, key=timeout_key, source=source))


def policy_of(options: Mapping[str, Any], *, source: str | None = None,
              prefix: str = "") -> FailsafePolicy | None:
    """The policy declared by a robot's or simulator's table (None if none is).

    `prefix` goes before the key names in errors ("components.sim_uav.").
    """
    return parse_policy(options.get(FAILSAFE_KEY), options.get(TIMEOUT_KEY), source=source,
                        keys=(prefix + FAILSAFE_KEY, prefix + TIMEOUT_KEY))


def failsafe_problems(options: Mapping[str, Any]) -> list[tuple[str, str]]:
    """(key, problem) for the failsafe keys of a table, for `mrss check`."""
    try:
        policy_of(options)
    except ConfigError as exc:
        return [(exc.key or FAILSAFE_KEY, exc.reason)]
    return []


def failsafe_reason(text: str) -> str:
    """A link-down reason of cause FAILSAFE."""
    return f"{LinkDownCause.FAILSAFE.value}: {text}"


def link_down_cause(reason: str) -> LinkDownCause:
    """The cause of a link-down reason: FAILSAFE for `failsafe_reason`'s, else UNREACHABLE."""
    if reason.startswith(f"{LinkDownCause.FAILSAFE.value}:"):
        return LinkDownCause.FAILSAFE
    return LinkDownCause.UNREACHABLE
