"""The HTTP robot link: JSON commands, polled telemetry and heartbeats to one robot's URL.

The link is a client only (the protocol is `mrss.links.http_protocol`). Rules:
- Telemetry: ``GET <url>/telemetry`` every `poll` seconds; each valid sample becomes
  `position`, `battery` (if the robot reports one) and `status` (on change) records.
- Up on the first valid sample and after every one while down; down when no poll has
  succeeded for longer than `timeout` (reason ``no telemetry from URL for 3.0 s: <last
  error>``). Before the first success the link is down with ``connecting to URL`` and,
  once a poll failed, that failure.
- Commands: ``POST <url>/command``, each request waiting at most `command_timeout`; an
  unanswered one is sent again with the same id, up to `retries` times, then
  CommandTimeout. A 2xx ack ``rejected``/``failed``/``cancelled``, a non-2xx answer or an
  answer that is not an ack of that id is CommandRejected; a robot that refuses the
  connection is LinkDown.
- Failsafe (mrss.links.failsafe), as the MQTT link: with a declared `failsafe`, a
  ``POST <url>/heartbeat`` every second while the controller lives, carrying the
  failsafe and its timeout. Telemetry ``failsafe: true`` not yet reported makes the link
  report the robot down (``failsafe: ...``); up again once it says ``controller: true``.
"""

from __future__ import annotations

import http.client
import itertools
import json
import os
import threading
import time
import urllib.error
import urllib.request
from typing import Any

from mrss.errors import ConfigError, DecodeError
from mrss.links.base import LinkStateCallback, RobotLink, TelemetryCallback
from mrss.links.errors import CommandRejected, CommandTimeout, LinkDown
from mrss.links.failsafe import (
    CONTROLLER_HEARTBEAT_S,
    FailsafePolicy,
)
from mrss.links.geo import distance_m
from mrss.links.http_protocol import (
    COMMAND_PATH,
    HEARTBEAT_PATH,
    TELEMETRY_PATH,
    HttpTelemetry,
    base_url,
    parse_telemetry,
)
from mrss.links.ugv_protocol import UgvAck, UgvHeartbeat, parse_ack

REFUSALS = ("rejected", "failed", "cancelled")


class HttpLink(RobotLink):
    """A link to one robot speaking the JSON-over-HTTP protocol of `http_protocol`."""

    kind = "http"

    def __init__(
        self, robot_id: str, url: str, *, poll: float = 0.5, timeout: float = 3.0,
        command_timeout: float = 2.0, retries: int = 3,
        on_link_state: LinkStateCallback | None = None,
        on_telemetry: TelemetryCallback | None = None,
        failsafe: FailsafePolicy | None = None,
    ) -> None:
        super().__init__(robot_id, on_link_state=on_link_state, on_telemetry=on_telemetry,
                         failsafe=failsafe)
        for key, value in (("poll", poll), ("timeout", timeout),
                           ("command_timeout", command_timeout), ("retries", retries)):
            if not value > 0:
                raise ConfigError(f"must be > 0, not {value!r}", key=key)
        self.url = base_url(url)
        self.poll = poll
        self.timeout = timeout
        self.command_timeout = command_timeout
        self.retries = retries
        self.bad_messages = 0
        self._opener = urllib.request.build_opener(urllib.request.ProxyHandler({}))
        self._last_ok: float | None = None
        self._last_status: tuple[str, bool] | None = None
        self._ids = itertools.count(1)
        self._token = f"{os.getpid():x}{id(self) & 0xFFFF:x}"
        self._stop = threading.Event()
        self._threads: list[threading.Thread] = []

    # -- life cycle ------------------------------------------------------------------------
    def start(self) -> None:
        """Start polling (and, with a failsafe, heartbeats) in the background."""
        self._set_link_state(False, f"connecting to {self.url}")
        loops = [self._poll_loop] + ([self._heartbeat_loop] if self.failsafe else [])
        for loop in loops:
            thread = threading.Thread(target=loop, name=f"http-{self.robot_id}", daemon=True)
            self._threads.append(thread)
            thread.start()

    def close(self) -> None:
        """Stop the threads; the link ends down ("link closed")."""
        self._stop.set()
        for thread in self._threads:
            thread.join(timeout=self.timeout + self.command_timeout + 1)
        self._mark_closed()

    # -- commands --------------------------------------------------------------------------
    def command(self, cmd: str, **fields: Any) -> UgvAck:
        """Send a command; return the robot's ack (CommandRejected, CommandTimeout, LinkDown)."""
        self.require_up()
        ident = f"{self.robot_id}-{self._token}-{next(self._ids)}"
        body = json.dumps({**{k: v for k, v in fields.items() if v is not None},
                           "id": ident, "cmd": cmd}).encode()
        for _ in range(self.retries):
            try:
                status, payload = self._request("POST", COMMAND_PATH, body,
                                                self.command_timeout)
            except TimeoutError:
                continue
            except OSError as exc:
                raise LinkDown(self.robot_id, f"{self.url}: {_why(exc)}") from None
            return self._ack(cmd, ident, status, payload)
        raise CommandTimeout(self.robot_id, cmd, self.command_timeout, self.retries)

    def goto(self, lat: float, lon: float, *, wait: bool = True, tolerance_m: float = 2.0,
             timeout: float = 600.0) -> UgvAck:
        """Drive to a point; with `wait`, return once telemetry puts it within `tolerance_m`."""
        ack = self.command("goto", lat=lat, lon=lon)
        if wait:
            self.wait_for(lambda: self._within(lat, lon, tolerance_m), timeout,
                          f"goto {lat:.6f},{lon:.6f}")
        return ack

    def stop(self) -> UgvAck:
        """Stop moving."""
        return self.command("stop")

    def _within(self, lat: float, lon: float, tolerance_m: float) -> bool:
        record = self._latest.get("position")
        return record is not None and \
            distance_m(record["lat"], record["lon"], lat, lon) <= tolerance_m

    def _ack(self, cmd: str, ident: str, status: int, payload: bytes) -> UgvAck:
        try:
            ack: UgvAck | None = parse_ack(payload, COMMAND_PATH)
        except DecodeError as exc:
            if 200 <= status < 300:
                self.bad_messages += 1
                raise CommandRejected(self.robot_id, cmd, f"bad answer: {exc}") from None
            ack = None
        if not 200 <= status < 300:
            reason = f": {ack.reason}" if ack is not None and ack.reason else ""
            raise CommandRejected(self.robot_id, cmd, f"HTTP {status}{reason}")
        assert ack is not None
        if ack.id != ident:
            self.bad_messages += 1
            raise CommandRejected(self.robot_id, cmd, f"bad answer: ack of {ack.id!r}, "
                                  f"not {ident!r}")
        if ack.status in REFUSALS:
            raise CommandRejected(self.robot_id, cmd, f"{ack.status}: {ack.reason}"
                                  if ack.reason else ack.status)
        return ack

    # -- HTTP --------------------------------------------------------------------------------
    def _request(self, method: str, path: str, body: bytes | None,
                 timeout: float) -> tuple[int, bytes]:
        """(status, body) of one request; OSError (TimeoutError) if there is no answer."""
        request = urllib.request.Request(self.url + path, data=body, method=method,
                                         headers={"Content-Type": "application/json"})
        try:
            with self._opener.open(request, timeout=timeout) as answer:
                return int(answer.status), bytes(answer.read())
        except urllib.error.HTTPError as exc:
            with exc:
                return int(exc.code), bytes(exc.read())
        except urllib.error.URLError as exc:
            if isinstance(exc.reason, OSError):
                raise exc.reason from None
            raise OSError(str(exc.reason)) from None
        except http.client.HTTPException as exc:  # a garbled or cut-off answer
            raise OSError(f"bad HTTP answer: {exc!r}") from None

    # -- telemetry ---------------------------------------------------------------------------
    def _poll_loop(self) -> None:
        while not self._stop.is_set():
            try:
                self._poll_once()
            except Exception:  # a bug here must not stop the link
                self.log.exception("error polling %s", self.url)
            self._stop.wait(self.poll)

    def _poll_once(self) -> None:
        try:
            status, payload = self._request("GET", TELEMETRY_PATH, None, self.timeout)
            if not 200 <= status < 300:
                raise OSError(f"HTTP {status}")
            sample = parse_telemetry(payload, self.robot_id)
        except DecodeError as exc:
            self.bad_messages += 1
            self.rejections.reject(self.robot_id, "bad telemetry", str(exc))
            self._failed(f"bad telemetry: {exc}")
            return
        except OSError as exc:
            self._failed(_why(exc))
            return
        self._last_ok = time.monotonic()
        self._on_telemetry(sample)

    def _failed(self, why: str) -> None:
        last = self._last_ok
        if last is None:
            self._set_link_state(False, f"connecting to {self.url}: {why}")
        elif time.monotonic() - last > self.timeout:
            self._set_link_state(False, f"no telemetry from {self.url} for "
                                 f"{self.timeout:.1f} s: {why}")

    def _on_telemetry(self, t: HttpTelemetry) -> None:
        self._follow_failsafe(t)
        if not self._in_failsafe:
            regained = self._failsafe_reported and not self.up
            self._set_link_state(True, "control regained after a failsafe" if regained
                                 else f"telemetry from {self.robot_id}")
        self._publish_telemetry("position", {"lat": t.lat, "lon": t.lon,
                                             "heading": t.heading, "speed": t.speed})
        if t.battery is not None:
            self._publish_telemetry("battery", {"remaining": t.battery, "voltage": None,
                                                "current": None})
        status = (t.mode, t.failsafe)
        if status != self._last_status:
            self._last_status = status
            self._publish_telemetry("status", {"mode": t.mode, "failsafe": t.failsafe})

    # -- failsafe ----------------------------------------------------------------------------
    def _follow_failsafe(self, t: HttpTelemetry) -> None:
        """Report a failsafe the robot took (once), and its end of it when it hears us."""
        self._follow_failsafe_state(t.failsafe, t.controller, t.mode)

    def _heartbeat_loop(self) -> None:
        while True:
            try:
                self._heartbeat()
            except Exception:  # a bug here must not stop the heartbeats
                self.log.exception("error sending a heartbeat to %s", self.url)
            if self._stop.wait(CONTROLLER_HEARTBEAT_S):
                return

    def _heartbeat(self) -> None:
        """POST one controller heartbeat, while a live controller runs the robot."""
        policy = self.failsafe
        if policy is None or not self._controlled():
            return
        beat = UgvHeartbeat(time.time(), policy.action, policy.timeout_s).to_json()
        try:
            self._request("POST", HEARTBEAT_PATH, beat, CONTROLLER_HEARTBEAT_S)
        except OSError as exc:
            self.log.debug("heartbeat not delivered: %s", _why(exc))


def _why(exc: OSError) -> str:
    """A short reason for a failed request ("connection refused", "timed out", "HTTP 500")."""
    if isinstance(exc, TimeoutError):
        return "timed out"
    if isinstance(exc, ConnectionRefusedError):
        return "connection refused"
    return str(exc) or type(exc).__name__
