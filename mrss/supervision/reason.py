"""Why a child stopped: one reason type for processes and actors alike.

"Link down" (the robot is unreachable) and "crashed" (our code failed) are different
causes on purpose: a lost link restarts with backoff but does not count against the
restart intensity, because it is not a bug to be escalated.
"""

from __future__ import annotations

import os
import signal
from dataclasses import dataclass
from enum import StrEnum

EXIT_CONFIG = 78  # sysexits EX_CONFIG: a component refused its configuration at start


class Cause(StrEnum):
    """The kind of a child's exit."""

    NORMAL = "normal"  # finished by itself without error (exit code 0)
    SHUTDOWN = "shutdown"  # stopped on purpose by its supervisor
    EXITED = "exited"  # a process exited with a non-zero code
    KILLED = "killed"  # a process died of a signal
    CRASHED = "crashed"  # an exception escaped the child's code
    HUNG = "hung"  # missed heartbeats, or blocked past its watchdog
    START_TIMEOUT = "start_timeout"  # did not report ready in time
    LINK_DOWN = "link_down"  # the robot link it serves is down
    ESCALATED = "escalated"  # a nested supervisor gave up
    CONFIG_ERROR = "config_error"  # refused its configuration at start: not restarted


@dataclass(frozen=True)
class ExitReason:
    """A cause plus human detail, e.g. `killed: SIGKILL` or `crashed: ValueError: bad`."""

    cause: Cause
    detail: str = ""

    @property
    def normal(self) -> bool:
        """True for exits that a transient child is not restarted after."""
        return self.cause in (Cause.NORMAL, Cause.SHUTDOWN)

    @property
    def counts_toward_intensity(self) -> bool:
        """False for a link going down: the robot is unreachable, our code did not fail."""
        return self.cause is not Cause.LINK_DOWN

    def __str__(self) -> str:
        return f"{self.cause.value}: {self.detail}" if self.detail else self.cause.value

    @classmethod
    def from_returncode(cls, code: int) -> ExitReason:
        """The reason for a process exit as `subprocess` reports it (negative = signal)."""
        if code == 0:
            return cls(Cause.NORMAL, "exit code 0")
        if code < 0:
            return cls(Cause.KILLED, signal_name(-code))
        if code == EXIT_CONFIG:
            return cls(Cause.CONFIG_ERROR, f"exit code {code}")
        return cls(Cause.EXITED, f"exit code {code}")

    @classmethod
    def from_wait_status(cls, status: int) -> ExitReason:
        """The reason for a process exit from a raw `os.waitpid` status."""
        if os.WIFSIGNALED(status):
            return cls(Cause.KILLED, signal_name(os.WTERMSIG(status)))
        return cls.from_returncode(os.WEXITSTATUS(status))

    @classmethod
    def crashed(cls, exc: BaseException) -> ExitReason:
        """The reason for an exception escaping a child's code."""
        return cls(Cause.CRASHED, f"{type(exc).__name__}: {exc}")


def signal_name(number: int) -> str:
    """`SIGKILL` for 9, or `signal 64` for numbers without a name."""
    try:
        return signal.Signals(number).name
    except ValueError:
        return f"signal {number}"
