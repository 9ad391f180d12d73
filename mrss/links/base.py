"""The interface every robot link offers the RCL's robot actor: state, telemetry, close.

A link is *up* while the robot answers and *down* with a reason a person can read
("no heartbeat for 3.0 s", "last will: offline", "telemetry timeout: none for 3.0 s").
Telemetry arrives as plain dicts with at least ``robot``, ``type`` and ``ts`` keys; the
fields of each type are listed in docs/robots.md. Callbacks run on the link's own thread:
they must return quickly and must not wait for a command of the same link.

The link is also the robot's controller as far as the robot's failsafe goes
(mrss.links.failsafe): it sends the robot heartbeats while `watch_controller`'s check
says that a live robot actor controls the robot, and it reports a failsafe the robot
took as a state callback ``(False, "failsafe: ...")``, even when the link was down already.
"""

from __future__ import annotations

import logging
import math
import threading
import time
from abc import ABC, abstractmethod
from collections.abc import Callable
from contextlib import AbstractContextManager, nullcontext
from typing import Any, TypeGuard

from mrss.edge.record_declarations import DEFAULT_LIMITS, LINK_TYPES, Limits, RobotType
from mrss.edge.rejections import RejectionLog
from mrss.edge.validation import RecordValidator, Rejected
from mrss.links.errors import CommandTimeout, LinkDown
from mrss.links.failsafe import FailsafeEvent, FailsafePolicy, failsafe_reason

Telemetry = dict[str, Any]
#: ((lat, lon) | None, battery % | None): `RobotLink.whereabouts`
Whereabouts = tuple[tuple[float, float] | None, float | None]
TelemetryCallback = Callable[[Telemetry], None]
LinkStateCallback = Callable[[bool, str], None]
SampleScope = Callable[[], AbstractContextManager[object]]


class RobotLink(ABC):
    """Common state and callback machinery of the MAVLink, MQTT and HTTP links."""

    kind = "robot"

    def __init__(
        self,
        robot_id: str,
        *,
        on_link_state: LinkStateCallback | None = None,
        on_telemetry: TelemetryCallback | None = None,
        failsafe: FailsafePolicy | None = None,
    ) -> None:
        self.robot_id = robot_id
        self.failsafe = failsafe
        self.log = logging.getLogger(f"mrss.links.{self.kind}.{robot_id}")
        #: Every record is checked against its declaration (mrss.edge.validation) with
        #: the limits of the robot's type before anyone sees it; refusals are counted.
        self.limits: Limits = DEFAULT_LIMITS[LINK_TYPES.get(self.kind, RobotType.GROUND)]
        self.rejections = RejectionLog(self.log, "telemetry record")
        self._validator: RecordValidator | None = None
        self._changed = threading.Condition()
        self._dispatch = threading.RLock()
        self._up = False
        self._reason = "not connected yet"
        self._closed = False
        self._latest: dict[str, Telemetry] = {}
        self._whereabouts: Whereabouts = (None, None)
        self._teleop = False  # the last `status` record says the robot is teleoperated
        self._controller_check: Callable[[], bool] | None = None
        self._controller_was = True
        self._failsafe_reported = False  # the robot's current failsafe was reported
        self._in_failsafe = False        # ... and it does not hear us yet
        self._state_callbacks: list[LinkStateCallback] = []
        self._telemetry_callbacks: list[TelemetryCallback] = []
        self._sample_scope: SampleScope = nullcontext
        if on_link_state is not None:
            self._state_callbacks.append(on_link_state)
        if on_telemetry is not None:
            self._telemetry_callbacks.append(on_telemetry)

    # -- what the robot actor uses -------------------------------------------------------
    @abstractmethod
    def start(self) -> None:
        """Open the connection and start the link's threads (returns without waiting)."""

    @abstractmethod
    def close(self) -> None:
        """Stop the link's threads and release its sockets; the link ends down."""

    @property
    def up(self) -> bool:
        """Whether the robot is reachable right now."""
        return self._up

    @property
    def reason(self) -> str:
        """Why the link is in its current state (the last transition's reason)."""
        return self._reason

    def add_link_state_callback(self, callback: LinkStateCallback) -> None:
        """Call `callback(up, reason)` on every transition between up and down."""
        self._state_callbacks.append(callback)

    def add_telemetry_callback(self, callback: TelemetryCallback) -> None:
        """Call `callback(record)` for every telemetry record received."""
        self._telemetry_callbacks.append(callback)

    def set_sample_scope(self, scope: SampleScope) -> None:
        """Hand the records of one telemetry sample (an MQTT robot's position, battery
        and tank; the MAVLink messages a UDP link reads in one go) to the callbacks
        inside one `scope()` block: the RCL's publisher then sends them as one bus
        message."""
        self._sample_scope = scope

    def watch_controller(self, check: Callable[[], bool]) -> None:
        """Send the robot heartbeats only while `check()` is true (a live controller).

        The RCL passes "a live robot actor runs this robot": with its actor gone, the
        robot hears no controller and its failsafe fires. A check that raises counts as
        true (logged): a bug here must not land the fleet.
        """
        self._controller_check = check

    def latest(self, kind: str) -> Telemetry | None:
        """The last telemetry record of a type ("position", "battery", ...), or None."""
        with self._changed:
            record = self._latest.get(kind)
            return dict(record) if record is not None else None

    def whereabouts(self) -> Whereabouts:
        """((lat, lon) of the last `position` record, `remaining` % of the last `battery`
        record), None for what has not come: what a robot's bids for tasks are computed
        from, kept as the records arrive so that reading it takes no lock and no copy."""
        return self._whereabouts

    def reports_teleop(self) -> bool:
        """Whether the robot's last `status` record says it is in teleoperation
        (`"teleop": true`): the robot itself says so, whoever switched it (an operator at
        the robot, a project's skill), and allocation does not give it tasks meanwhile."""
        return self._teleop

    def require_up(self) -> None:
        """Raise LinkDown with the current reason unless the link is up."""
        if not self._up:
            raise LinkDown(self.robot_id, self._reason)

    def wait_up(self, timeout: float) -> None:
        """Block until the link is up; LinkDown with the last reason after `timeout`."""
        with self._changed:
            if not self._changed.wait_for(lambda: self._up or self._closed, timeout):
                raise LinkDown(self.robot_id, f"{self._reason} (waited {timeout:.1f} s)")
        self.require_up()

    def wait_for(self, condition: Callable[[], bool], timeout: float, what: str) -> None:
        """Block until `condition()` holds, re-checked on every telemetry or state change.

        Raises LinkDown if the link goes down first and CommandTimeout after `timeout`.
        """
        deadline = time.monotonic() + timeout
        with self._changed:
            while True:
                if condition():
                    return
                if not self._up:
                    raise LinkDown(self.robot_id, f"{self._reason} (while waiting: {what})")
                remaining = deadline - time.monotonic()
                if remaining <= 0:
                    raise CommandTimeout(self.robot_id, what, timeout)
                self._changed.wait(min(remaining, 0.5))

    # -- what the concrete links use -----------------------------------------------------
    def _controlled(self) -> bool:
        """Whether the robot has a live controller now (heartbeats go out only then)."""
        check = self._controller_check
        try:
            alive = True if check is None else bool(check())
        except Exception:
            self.log.exception("controller check failed; heartbeats go on")
            alive = True
        if alive != self._controller_was:
            self._controller_was = alive
            self.log.warning("controller %s: heartbeats to the robot %s", "back" if alive
                             else "gone", "resume" if alive else "stop")
        return alive

    def _follow_failsafe_state(self, failsafe: bool, controller: bool, mode: str,
                               where: str = "") -> None:
        """For a robot whose telemetry says whether it is in its failsafe and whether it
        hears its controller (MQTT UGV, HTTP): report a failsafe it took, once, and
        record its end of it once it hears us."""
        if not failsafe:
            self._failsafe_reported = self._in_failsafe = False  # commanded since
            return
        if not self._failsafe_reported:
            self._failsafe_reported = self._in_failsafe = True
            self._failsafe_record(FailsafeEvent.TRIGGERED, mode)
            self._report_failsafe(failsafe_reason(
                f"{self.robot_id} lost its controller and took its failsafe (now "
                f"{mode}{where})"))
        if self._in_failsafe and controller:
            self._in_failsafe = False
            self._failsafe_record(FailsafeEvent.REGAINED, mode)

    def _failsafe_record(self, event: FailsafeEvent, mode: str) -> None:
        action = self.failsafe.action.value if self.failsafe else None
        self._publish_telemetry("failsafe", {"event": event.value, "action": action,
                                             "mode": mode, "detail": f"robot {mode}"})

    def _report_failsafe(self, reason: str) -> None:
        """The robot took its failsafe: down with `reason` (a `failsafe_reason`), told to
        the callbacks even if the link was down already."""
        with self._dispatch:
            with self._changed:
                if self._closed:
                    return
                self._up = False
                self._reason = reason
                self._changed.notify_all()
            self.log.warning("link down: %s", reason)
            for callback in list(self._state_callbacks):
                try:
                    callback(False, reason)
                except Exception:
                    self.log.exception("link state callback failed")

    def _set_link_state(self, up: bool, reason: str) -> bool:
        """Record a state; on a change, log it and tell the callbacks. Returns if it changed."""
        with self._dispatch:
            with self._changed:
                if up and self._closed:
                    return False
                if up == self._up:
                    if not up and not self._closed:
                        self._reason = reason  # still down, for a newer reason
                        self._changed.notify_all()
                    return False
                self._up = up
                self._reason = reason
                self._changed.notify_all()
            self.log.info("link %s: %s", "up" if up else "down", reason)
            for callback in list(self._state_callbacks):
                try:
                    callback(up, reason)
                except Exception:
                    self.log.exception("link state callback failed")
        return True

    def _mark_closed(self) -> None:
        with self._changed:
            self._closed = True
        self._set_link_state(False, "link closed")
        with self._changed:
            self._reason = "link closed"
            self._changed.notify_all()

    def _publish_telemetry(self, kind: str, fields: dict[str, Any]) -> Telemetry | None:
        """Store a telemetry record of type `kind` and hand it to the callbacks; a record
        outside its declaration (mrss.edge.validation) is refused: counted, logged once
        per reason and interval, neither stored nor handed on (None)."""
        record: Telemetry = {"robot": self.robot_id, "type": kind, "ts": time.time(), **fields}
        try:
            if self._validator is None or self._validator.default is not self.limits:
                self._validator = RecordValidator([self.robot_id], default=self.limits)
            self._validator.check(self.robot_id, record)
        except Rejected as exc:
            self.rejections.reject(self.robot_id, exc.reason, exc.detail)
            return None
        with self._changed:
            self._latest[kind] = record
            if kind in ("position", "battery"):
                self._whereabouts = _whereabouts(self._whereabouts, kind, record)
            elif kind == "status":
                self._teleop = record.get("teleop") is True
            self._changed.notify_all()
        with self._dispatch:
            for callback in list(self._telemetry_callbacks):
                try:
                    callback(dict(record))
                except Exception:
                    self.log.exception("telemetry callback failed")
        return record

    def _notify(self) -> None:
        """Wake `wait_for` callers after an internal change that is not telemetry."""
        with self._changed:
            self._changed.notify_all()


def _whereabouts(was: Whereabouts, kind: str, record: Telemetry) -> Whereabouts:
    """`was` with a new `position` or `battery` record."""
    if kind == "position":
        lat, lon = record.get("lat"), record.get("lon")
        place = (float(lat), float(lon)) if _finite(lat) and _finite(lon) else None
        return place, was[1]
    remaining = record.get("remaining")
    return was[0], float(remaining) if _finite(remaining) else None


def _finite(value: Any) -> TypeGuard[float]:
    return isinstance(value, int | float) and not isinstance(value, bool) \
        and math.isfinite(value)
