"""When a simulated robot has lost its controller: ArduPilot's GCS-failsafe timing rules.

Pure timing, no I/O; times are wall-clock seconds (`time.monotonic()`), never simulated
ones, because the controller's heartbeats come at wall-clock rates whatever the speedup.
- Until a controller is heard once, nothing happens (ArduPilot: "if no GCS is ever
  connected, the GCS failsafe remains inactive").
- Heard, then silent for longer than the timeout: LOST, once.
- Heard again while lost: REGAINED, once. What the robot does then (ArduPilot: nothing,
  it stays in its failsafe mode until commanded) is the robot's business.
"""

from __future__ import annotations

from enum import StrEnum


class WatchEvent(StrEnum):
    """A change of the controller's presence."""

    LOST = "lost"
    REGAINED = "regained"


class ControllerWatch:
    """Watches one controller's heartbeats against a timeout."""

    def __init__(self, timeout_s: float) -> None:
        if timeout_s <= 0:
            raise ValueError("the controller timeout must be positive")
        self.timeout_s = timeout_s
        self.lost = False
        self._last_heard: float | None = None

    def heard(self, now: float) -> None:
        """The controller's heartbeat arrived at `now`."""
        self._last_heard = now

    @property
    def heard_once(self) -> bool:
        """Whether a controller was ever heard (since the last `reset`)."""
        return self._last_heard is not None

    def present(self, now: float) -> bool:
        """Whether the controller was heard within the timeout."""
        last = self._last_heard
        return last is not None and now - last <= self.timeout_s

    def poll(self, now: float) -> WatchEvent | None:
        """The event due at `now`, if any (each one is returned once)."""
        if self._last_heard is None:
            return None
        silent = now - self._last_heard > self.timeout_s
        if silent and not self.lost:
            self.lost = True
            return WatchEvent.LOST
        if not silent and self.lost:
            self.lost = False
            return WatchEvent.REGAINED
        return None

    def reset(self) -> None:
        """Forget the controller (the failsafe was disabled): inactive until heard again."""
        self.lost = False
        self._last_heard = None
