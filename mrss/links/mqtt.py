"""The MQTT robot link: JSON commands and telemetry of one ground robot (or manipulator).

The link is up while the broker connection stands, the robot's retained status is not
"offline" and valid telemetry keeps arriving; it goes down with the reason
("broker connection lost: ...", "last will: offline", "telemetry timeout: none for 3.0 s").
The links of a process that log in to a broker alike share one connection
(mrss.links.mqtt_session), which paho reconnects with a growing delay. Command helpers
block until the robot accepts (and, with ``wait=True``, finishes) the command, repeating
an unanswered command with the same id (the robot answers repeats without doing them
twice).

Failsafe (mrss.links.failsafe): the link publishes a controller heartbeat every second
on the robot's ``heartbeat`` topic while its controller lives (`watch_controller`),
carrying the declared `failsafe`, if any. Telemetry with ``failsafe: true`` that the
link has not reported yet makes it report the robot down (``failsafe: ...``); it is up
again once the robot's telemetry says it hears the heartbeats (``controller: true``).
"""

from __future__ import annotations

import itertools
import os
import threading
import time
from typing import Any

from mrss.errors import DecodeError
from mrss.links.base import LinkStateCallback, RobotLink, TelemetryCallback
from mrss.links.errors import CommandRejected, CommandTimeout, LinkDown
from mrss.links.failsafe import (
    CONTROLLER_HEARTBEAT_S,
    FailsafePolicy,
)
from mrss.links.mqtt_session import MqttSession
from mrss.links.mqtt_url import parse_broker_url, with_login
from mrss.links.timers import TIMERS, TimerHandle
from mrss.links.ugv_protocol import (
    DEFAULT_PREFIX,
    OFFLINE,
    ONLINE,
    UgvAck,
    UgvCommand,
    UgvHeartbeat,
    UgvTelemetry,
    UgvTopics,
    parse_ack,
    parse_telemetry,
)

WATCH_IDLE_S = 0.1   # before the broker connection: look again this soon for a heartbeat
WATCH_SLACK_S = 0.01  # run the watchdog this long after a deadline (never busy-loop)


class MqttLink(RobotLink):
    """A link to one MQTT robot speaking the protocol of `mrss.links.ugv_protocol`."""

    kind = "mqtt"

    def __init__(
        self, robot_id: str, broker_url: str, *, prefix: str = DEFAULT_PREFIX,
        topics: UgvTopics | None = None, telemetry_timeout: float = 3.0,
        command_timeout: float = 2.0, retries: int = 3, keepalive: int = 5,
        on_link_state: LinkStateCallback | None = None,
        on_telemetry: TelemetryCallback | None = None,
        failsafe: FailsafePolicy | None = None, username: str | None = None,
        password_file: str | None = None, ca_certs: str | None = None,
        certfile: str | None = None, keyfile: str | None = None,
    ) -> None:
        super().__init__(robot_id, on_link_state=on_link_state, on_telemetry=on_telemetry,
                         failsafe=failsafe)
        self.address = with_login(parse_broker_url(broker_url), username=username,
                                  password_file=password_file, ca_certs=ca_certs,
                                  certfile=certfile, keyfile=keyfile)
        self.topics = topics or UgvTopics.for_robot(robot_id, prefix)
        self.telemetry_timeout = telemetry_timeout
        self.command_timeout = command_timeout
        self.retries = retries
        self.keepalive = keepalive
        self.bad_messages = 0
        self._connected = False
        self._online: bool | None = None
        self._last_telemetry: float | None = None
        self._last_status: tuple[str, bool, bool, bool] | None = None
        self._waiting: dict[str, UgvAck | None] = {}
        self._ids = itertools.count(1)
        self._token = f"{os.getpid():x}{id(self) & 0xFFFF:x}"
        self._stop = threading.Event()
        self._watchdog: TimerHandle | None = None
        self._next_heartbeat = 0.0
        self._session: MqttSession | None = None

    # -- life cycle ------------------------------------------------------------------------
    def start(self) -> None:
        """Join the process's connection to the broker (mrss.links.mqtt_session: made in
        the background for the first link, retrying with backoff) and start the watchdog
        (a job of the process's shared link timer thread, mrss.links.timers)."""
        self._set_link_state(False, f"connecting to {self.address.host}:{self.address.port}")
        self._session = MqttSession.attach(self.address, self.keepalive, self)
        self._watchdog = TIMERS.schedule(self._watch, name=f"mqtt-{self.robot_id}")

    def close(self) -> None:
        """Disconnect and stop; the link ends down ("link closed")."""
        self._stop.set()
        session, self._session = self._session, None
        if session is not None:
            session.detach(self)
        self._connected = False
        if self._watchdog is not None:
            self._watchdog.cancel()
        self._mark_closed()

    # -- commands --------------------------------------------------------------------------
    def command(self, cmd: str, *, wait: bool = False, timeout: float = 60.0,
                **fields: Any) -> UgvAck:
        """Send a command; return the robot's answer ("accepted" or, with `wait`, "done").

        Raises CommandRejected if the robot refuses, fails or cancels it, CommandTimeout
        if it does not answer, LinkDown if the link is or goes down meanwhile.
        """
        self.require_up()
        ident = f"{self.robot_id}-{self._token}-{next(self._ids)}"
        payload = UgvCommand(cmd, ident, **fields).to_json()
        with self._changed:
            self._waiting[ident] = None
        try:
            self._publish_until_answered(cmd, ident, payload)
            if wait:
                self.wait_for(lambda: self._answer(ident).terminal, timeout, cmd)
            answer = self._answer(ident)
        finally:
            with self._changed:
                self._waiting.pop(ident, None)
        if answer.status in ("rejected", "failed", "cancelled"):
            reason = f"{answer.status}: {answer.reason}" if answer.reason else answer.status
            raise CommandRejected(self.robot_id, cmd, reason)
        return answer

    def goto(self, lat: float, lon: float, *, wait: bool = True,
             timeout: float = 600.0) -> UgvAck:
        """Drive to a point; with `wait`, return on arrival."""
        return self.command("goto", lat=lat, lon=lon, wait=wait, timeout=timeout)

    def return_to_base(self, *, wait: bool = True, timeout: float = 600.0) -> UgvAck:
        """Drive back to base (where the tank refills and the battery charges)."""
        return self.command("return_to_base", wait=wait, timeout=timeout)

    def go_home(self) -> None:
        """What a stand-down by area (mode home) asks of any link: back to base."""
        self.return_to_base(wait=False)

    def stop(self) -> UgvAck:
        """Stop driving and pumping; running commands end "cancelled"."""
        return self.command("stop")

    def pump(self, on: bool, litres: float | None = None, *, wait: bool = False,
             timeout: float = 600.0) -> UgvAck:
        """Start (optionally for `litres`) or stop the pump; `wait` for the amount."""
        return self.command("pump", on=on, litres=litres, wait=wait, timeout=timeout)

    def teleop(self, on: bool) -> UgvAck:
        """Hand the robot to (or take it back from) remote driving."""
        return self.command("teleop", on=on)

    def drive(self, speed: float, heading: float) -> UgvAck:
        """Remote driving: speed m/s on a heading in degrees (teleop only)."""
        return self.command("drive", speed=speed, heading=heading)

    def _answer(self, ident: str) -> UgvAck:
        answer = self._waiting.get(ident)
        assert answer is not None
        return answer

    def _publish_until_answered(self, cmd: str, ident: str, payload: bytes) -> None:
        for _ in range(self.retries):
            if not self._publish(self.topics.cmd, payload, qos=1):
                raise LinkDown(self.robot_id, "link closed")
            try:
                self.wait_for(lambda: self._waiting.get(ident) is not None,
                              self.command_timeout, cmd)
                return
            except CommandTimeout:
                continue
        raise CommandTimeout(self.robot_id, cmd, self.command_timeout, self.retries)

    def _publish(self, topic: str, payload: bytes, qos: int) -> bool:
        """Publish through the session; False once the link is closed."""
        session = self._session
        if session is None:
            return False
        session.publish(topic, payload, qos)
        return True

    # -- the shared session's callbacks (its network thread) -------------------------------
    def session_topics(self) -> tuple[str, ...]:
        return (self.topics.status, self.topics.telemetry, self.topics.ack)

    def session_connected(self) -> None:
        self._connected = True
        self._heartbeat()  # the robot hears its controller at once
        self.log.info("connected to broker %s:%d", self.address.host, self.address.port)

    def session_down(self, reason: str) -> None:
        self._connected = False
        if not self._stop.is_set():
            self._set_link_state(False, reason)

    def session_message(self, topic: str, payload: bytes) -> None:
        try:
            if topic == self.topics.telemetry:
                self._on_telemetry(parse_telemetry(payload, self.robot_id, topic))
            elif topic == self.topics.ack:
                self._on_ack(parse_ack(payload, topic))
            elif topic == self.topics.status:
                self._on_status(payload, topic)
        except DecodeError as exc:
            self.bad_messages += 1
            self.rejections.reject(self.robot_id, f"bad message on {topic}", str(exc))
        except Exception:  # a bug here must not stop the link
            self.log.exception("error handling a message on %s", topic)

    def _on_status(self, payload: bytes, topic: str) -> None:
        text = payload.decode("utf-8", "replace").strip()
        if text == ONLINE:
            self._online = True
            self._evaluate()
        elif text == OFFLINE:
            self._online = False
            self._set_link_state(False, f"last will: {OFFLINE}")
        else:
            raise DecodeError(f"status must be {ONLINE!r} or {OFFLINE!r}", topic=topic)

    def _on_ack(self, ack: UgvAck) -> None:
        with self._changed:
            if ack.id in self._waiting:
                current = self._waiting[ack.id]
                if current is None or not current.terminal:
                    self._waiting[ack.id] = ack
                self._changed.notify_all()

    def _on_telemetry(self, t: UgvTelemetry) -> None:
        self._last_telemetry = time.monotonic()
        self._follow_failsafe(t)
        self._evaluate()
        with self._sample_scope():  # the records of one sample go out together
            self._publish_telemetry("position", {"lat": t.lat, "lon": t.lon,
                                                 "heading": t.heading, "speed": t.speed})
            self._publish_telemetry("battery", {"remaining": t.battery, "voltage": None,
                                                "current": None})
            self._publish_telemetry("tank", {"level": t.tank,
                                             "capacity": t.tank_capacity,
                                             "pumping": t.pumping})
            status = (t.mode, t.at_base, t.teleop, t.failsafe)
            if status != self._last_status:
                self._last_status = status
                self._publish_telemetry("status", {"mode": t.mode, "at_base": t.at_base,
                                                   "teleop": t.teleop,
                                                   "failsafe": t.failsafe})

    # -- failsafe --------------------------------------------------------------------------
    def _follow_failsafe(self, t: UgvTelemetry) -> None:
        """Report a failsafe the robot took (once), and its end of it when it hears us."""
        self._follow_failsafe_state(t.failsafe, t.controller, t.mode,
                                    ", at base" if t.at_base else "")

    def _heartbeat(self) -> bool:
        """Publish one controller heartbeat; False if there is no one to send it to."""
        if not self.topics.heartbeat or not self._connected:
            return False
        if self._controlled():
            policy = self.failsafe
            beat = UgvHeartbeat(time.time(), policy.action if policy else None,
                                policy.timeout_s if policy else None)
            return self._publish(self.topics.heartbeat, beat.to_json(), qos=0)
        return True

    # -- liveness --------------------------------------------------------------------------
    def _evaluate(self) -> None:
        last = self._last_telemetry
        fresh = last is not None and time.monotonic() - last <= self.telemetry_timeout
        if self._connected and self._online is not False and fresh and not self._in_failsafe:
            regained = self._failsafe_reported and not self.up
            self._set_link_state(True, "control regained after a failsafe" if regained
                                 else f"telemetry from {self.robot_id}")

    def _watch(self) -> float | None:
        """The watchdog job: the controller heartbeat when due, down once telemetry is
        older than `telemetry_timeout`; returns the seconds until the next of both."""
        if self._stop.is_set():
            return None
        now = time.monotonic()
        if now >= self._next_heartbeat:
            self._next_heartbeat = now + (CONTROLLER_HEARTBEAT_S if self._heartbeat()
                                          else WATCH_IDLE_S)
        # down: look again within a timeout, for telemetry that may bring it up meanwhile
        wake = min(self._next_heartbeat, now + self.telemetry_timeout)
        last = self._last_telemetry
        if self.up and last is not None:
            if now - last > self.telemetry_timeout:
                self._set_link_state(
                    False, f"telemetry timeout: none for {self.telemetry_timeout:.1f} s")
            else:
                wake = min(wake, last + self.telemetry_timeout + WATCH_SLACK_S)
        return max(wake - now, WATCH_SLACK_S)
