"""The MAVLink link's side of a vehicle's GCS failsafe: configure it, notice it fired.

- Configure (`FailsafeParams`): a declared `FailsafePolicy` becomes FS_GCS_ENABLE (see
  `mrss.links.ardupilot.FS_GCS_ENABLE_OF`) and FS_GCS_TIMEOUT (seconds). Each parameter is
  sent on every connect and again every `retry_s` until the vehicle echoes the value we
  asked for, at most `attempts` times; a vehicle that never confirms keeps its own setting
  and the link says so (a ``not_configured`` failsafe record and the log).
- Notice (`VehicleFailsafe`): ``GCS Failsafe...`` from the vehicle starts a failsafe
  episode: the link reports the robot down with a ``failsafe:`` reason (even if it was
  down already) and stays down until the vehicle hears it again — a HEARTBEAT that is not
  MAV_STATE_CRITICAL, or one after ``GCS Failsafe Cleared``. A ``Cleared`` without the
  start (a new link incarnation, a lost datagram) is an episode all the same. One
  ``Cleared`` after an episode that a heartbeat already ended is not a new one.
"""

from __future__ import annotations

import logging
from collections.abc import Callable
from dataclasses import dataclass

from mrss.links.ardupilot import (
    FS_GCS_ENABLE,
    FS_GCS_ENABLE_OF,
    FS_GCS_TIMEOUT,
    GcsFailsafeEvent,
    gcs_failsafe_event,
)
from mrss.links.failsafe import FailsafeEvent, FailsafePolicy, failsafe_reason

TOLERANCE = 1e-3


@dataclass
class _Pending:
    value: float
    attempts: int = 0
    next_at: float = 0.0


class FailsafeParams:
    """The PARAM_SET exchange for one policy; the link sends what `due` returns."""

    def __init__(self, policy: FailsafePolicy, retry_s: float, attempts: int) -> None:
        self.wanted = {FS_GCS_ENABLE: float(FS_GCS_ENABLE_OF[policy.action]),
                       FS_GCS_TIMEOUT: float(policy.timeout_s)}
        self.retry_s = retry_s
        self.attempts = max(1, attempts)
        self._pending: dict[str, _Pending] = {}
        self.failed: set[str] = set()

    def begin(self) -> None:
        """(Re)connected: set every parameter again (the vehicle may have rebooted)."""
        self._pending = {name: _Pending(value) for name, value in self.wanted.items()}
        self.failed = set()

    def due(self, now: float) -> list[tuple[str, float]]:
        """The PARAM_SETs to send at `now` (each counts as an attempt)."""
        out = []
        for name, pending in self._pending.items():
            if pending.attempts < self.attempts and now >= pending.next_at:
                pending.attempts += 1
                pending.next_at = now + self.retry_s
                out.append((name, pending.value))
        return out

    def unconfirmed(self, now: float) -> list[str]:
        """Parameters given up on at `now` (every attempt made and waited for); dropped."""
        gone = [name for name, p in self._pending.items()
                if p.attempts >= self.attempts and now >= p.next_at]
        for name in gone:
            del self._pending[name]
        self.failed.update(gone)
        return gone

    @property
    def pending(self) -> bool:
        """Whether a parameter still waits for its confirmation (or its next attempt)."""
        return bool(self._pending)

    def confirm(self, name: str, value: float) -> bool:
        """A PARAM_VALUE arrived; True when it confirms the last pending parameter and
        none was given up on."""
        pending = self._pending.get(name)
        if pending is None or abs(value - pending.value) > TOLERANCE:
            return False
        del self._pending[name]
        return not self._pending and not self.failed


class VehicleFailsafe:
    """One link's failsafe bookkeeping; the link feeds it messages and acts on its calls.

    `send_param(name, value)` sends a PARAM_SET, `record(event, detail)` publishes a
    failsafe telemetry record, `down(reason)` reports the failsafe, `up(reason)` sets the
    link up (True if it changed), `mode()` is the vehicle's last reported mode.
    """

    def __init__(self, robot_id: str, policy: FailsafePolicy | None, retry_s: float,
                 attempts: int, *, send_param: Callable[[str, float], None],
                 record: Callable[[FailsafeEvent, str], None],
                 down: Callable[[str], None], up: Callable[[str], bool],
                 mode: Callable[[], str | None], log: logging.Logger) -> None:
        self.robot_id, self.policy, self.log = robot_id, policy, log
        self.params = FailsafeParams(policy, retry_s, attempts) if policy else None
        self._send_param, self._record, self._down, self._up = send_param, record, down, up
        self._mode = mode
        self.active = False            # the vehicle took its failsafe and does not hear us yet
        self._cleared = False          # ... and said "GCS Failsafe Cleared"
        self._expect_cleared = False   # a "Cleared" is still to come for an ended episode

    def connected(self) -> None:
        """The link came up: (re)configure the vehicle."""
        if self.params is not None:
            self.params.begin()

    @property
    def busy(self) -> bool:
        """Whether `tick` has work: parameters being set."""
        return self.params is not None and self.params.pending

    def tick(self, now: float) -> None:
        """Send the PARAM_SETs that are due; give up on unconfirmed ones."""
        if self.params is None:
            return
        for name, value in self.params.due(now):
            self._send_param(name, value)
        failed = self.params.unconfirmed(now)
        if failed:
            self.log.error("vehicle did not confirm %s: its own GCS failsafe setting stays",
                           ", ".join(failed))
            self._record(FailsafeEvent.NOT_CONFIGURED,
                         f"no PARAM_VALUE confirmed {', '.join(failed)}")

    def on_param(self, name: str, value: float) -> None:
        if self.params is not None and self.policy is not None \
                and self.params.confirm(name, value):
            self.log.info("failsafe configured: %s", self.policy.describe())
            self._record(FailsafeEvent.CONFIGURED, self.policy.describe())

    def on_text(self, text: str) -> None:
        event = gcs_failsafe_event(text)
        if event is GcsFailsafeEvent.ON:
            self._triggered(text)
        elif event is GcsFailsafeEvent.CLEARED:
            if self._expect_cleared and not self.active:
                self._expect_cleared = False  # the end of an episode already reported
                return
            self._triggered(text)  # if we missed its start: it happened all the same
            self._cleared = True   # up with the next heartbeat, which has the mode it chose

    def on_heartbeat(self, critical: bool) -> bool:
        """A vehicle heartbeat; True if it belongs to an episode (the link stays as it is)."""
        if not self.active:
            return False
        if self._cleared or not critical:  # the vehicle hears us again
            self.active, self._expect_cleared = False, not self._cleared
            mode = self._mode()
            self._record(FailsafeEvent.REGAINED, f"vehicle in {mode}")
            if self._up(f"control regained after a failsafe; vehicle in {mode}"):
                self.connected()
        return True

    def _triggered(self, text: str) -> None:
        if self.active:
            return
        self.active, self._expect_cleared, self._cleared = True, False, False
        self._record(FailsafeEvent.TRIGGERED, text)
        self._down(failsafe_reason(
            f"{self.robot_id} lost its controller and took its failsafe (vehicle: {text!r})"))
