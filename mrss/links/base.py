"""The interface every robot link offers the RCL's robot actor: state, telemetry, close.

A link is *up* while the robot answers and *down* with a reason a person can read
("no heartbeat for 3.0 s", "last will: offline", "telemetry timeout: none for 3.0 s").
Telemetry arrives as plain dicts with at least ``robot``, ``type`` and ``ts`` keys; the
fields of each type are listed in docs/robots.md. Callbacks run on the link's own thread:
they must return quickly and must not wait for a command of the same link.
"""

from __future__ import annotations

import logging
import threading
import time
from abc import ABC, abstractmethod
from collections.abc import Callable
from typing import Any

from mrss.links.errors import CommandTimeout, LinkDown

Telemetry = dict[str, Any]
TelemetryCallback = Callable[[Telemetry], None]
LinkStateCallback = Callable[[bool, str], None]


class RobotLink(ABC):
    """Common state and callback machinery of the MAVLink, MQTT (and later HTTP) links."""

    kind = "robot"

    def __init__(
        self,
        robot_id: str,
        *,
        on_link_state: LinkStateCallback | None = None,
        on_telemetry: TelemetryCallback | None = None,
    ) -> None:
        self.robot_id = robot_id
        self.log = logging.getLogger(f"mrss.links.{self.kind}.{robot_id}")
        self._changed = threading.Condition()
        self._dispatch = threading.RLock()
        self._up = False
        self._reason = "not connected yet"
        self._closed = False
        self._latest: dict[str, Telemetry] = {}
        self._state_callbacks: list[LinkStateCallback] = []
        self._telemetry_callbacks: list[TelemetryCallback] = []
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

    def latest(self, kind: str) -> Telemetry | None:
        """The last telemetry record of a type ("position", "battery", ...), or None."""
        with self._changed:
            record = self._latest.get(kind)
            return dict(record) if record is not None else None

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

    def _publish_telemetry(self, kind: str, fields: dict[str, Any]) -> Telemetry:
        """Store a telemetry record of type `kind` and hand it to the callbacks."""
        record: Telemetry = {"robot": self.robot_id, "type": kind, "ts": time.time(), **fields}
        with self._changed:
            self._latest[kind] = record
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
