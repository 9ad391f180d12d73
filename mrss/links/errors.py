"""Errors a robot link raises to the skill that called it, each naming the robot involved."""

from __future__ import annotations

from mrss.errors import MrssError


class LinkError(MrssError):
    """A robot link could not do what was asked."""

    def __init__(self, robot: str, reason: str) -> None:
        self.robot = robot
        self.reason = reason
        super().__init__(f"robot {robot}: {reason}")


class LinkDown(LinkError):
    """The robot is unreachable (no heartbeat, last will, telemetry timeout, closed link)."""


class CommandRejected(LinkError):
    """The robot answered a command with a refusal or a failure."""

    def __init__(self, robot: str, command: str, result: str) -> None:
        self.command = command
        self.result = result
        super().__init__(robot, f"command {command} rejected: {result}")


class CommandTimeout(LinkError):
    """The robot did not answer (or finish) a command in time, after all retries."""

    def __init__(self, robot: str, command: str, timeout: float, attempts: int = 1,
                 still: str = "") -> None:
        self.command = command
        self.timeout = timeout
        self.attempts = attempts
        tries = f" after {attempts} attempts" if attempts > 1 else ""
        state = f", {still}" if still else ""
        super().__init__(robot, f"command {command} timed out ({timeout:.1f} s){tries}{state}")
