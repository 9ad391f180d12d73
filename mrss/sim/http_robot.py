"""A simulated robot behind the JSON-over-HTTP protocol of `mrss.links.http_protocol`.

It drives in a straight line toward the last commanded point at `speed` m/s and reports
its position on ``GET /telemetry``. Commands (``POST /command``): ``goto`` (``lat``,
``lon``) answers ``accepted``, ``stop`` and ``return_to_base`` ``done``/``accepted``;
anything malformed or unknown is a 400 with a ``rejected`` ack saying why; a repeated id
is answered again, not redone. ``POST /heartbeat`` is the controller's heartbeat: with
a failsafe (its own or the one a heartbeat asks for), a robot that heard one and then
none for the timeout stops (``hold``/``stop``) or heads home (``rtl``) and reports
``failsafe: true`` until its next command, as the MQTT UGV does.

State is computed when asked (no thread of its own): the position at time t follows
from the last command. `fail_with(500)` makes every answer that status (a robot whose
software is broken); `stop()`/`start()` take it off and back on the same port.
"""

from __future__ import annotations

import json
import threading
import time
from collections import OrderedDict
from http.server import BaseHTTPRequestHandler, ThreadingHTTPServer
from typing import Any

from mrss.errors import DecodeError
from mrss.links.failsafe import FailsafeAction, FailsafePolicy
from mrss.links.geo import distance_m, step_towards
from mrss.links.http_protocol import COMMAND_PATH, HEARTBEAT_PATH, TELEMETRY_PATH, HttpTelemetry
from mrss.links.ugv_protocol import UgvAck, command_id_of, parse_command, parse_heartbeat

MAX_REMEMBERED_IDS = 256
MAX_BODY = 64 * 1024


class SimHttpRobot:
    """One simulated HTTP robot on `host`:`port` (0: a free port, kept across restarts)."""

    def __init__(self, robot_id: str, home: tuple[float, float], *, speed: float = 5.0,
                 host: str = "127.0.0.1", port: int = 0,
                 failsafe: FailsafePolicy | None = None) -> None:
        self.robot_id = robot_id
        self.home = home
        self.speed = speed
        self.host = host
        self.port = port
        self.failsafe = failsafe
        self.commands: list[dict[str, Any]] = []  # every command done, in order
        self.heartbeats = 0
        self._lock = threading.Lock()
        self._lat, self._lon = home
        self._target: tuple[float, float] | None = None
        self._mode = "idle"
        self._clock = time.monotonic()
        self._last_heartbeat: float | None = None
        self._in_failsafe = False
        self._answered: OrderedDict[str, tuple[int, UgvAck]] = OrderedDict()
        self._fail_status: int | None = None
        self._server: ThreadingHTTPServer | None = None
        self._thread: threading.Thread | None = None

    @property
    def url(self) -> str:
        return f"http://{self.host}:{self.port}"

    # -- life cycle ------------------------------------------------------------------------
    def start(self) -> None:
        """Serve on a thread (the same port as before after a `stop()`)."""
        robot = self

        class Handler(_Handler):
            sim = robot

        self._server = ThreadingHTTPServer((self.host, self.port), Handler)
        self._server.daemon_threads = True
        self.port = int(self._server.server_address[1])
        self._thread = threading.Thread(target=self._server.serve_forever,
                                        name=f"sim-http-{self.robot_id}", daemon=True)
        self._thread.start()

    def stop(self) -> None:
        """Stop serving (connections are refused until `start()`)."""
        if self._server is not None:
            self._server.shutdown()
            self._server.server_close()
            self._server = None
        if self._thread is not None:
            self._thread.join(timeout=5)

    def fail_with(self, status: int | None) -> None:
        """Answer every request with `status` (None: answer normally again)."""
        self._fail_status = status

    # -- the model -------------------------------------------------------------------------
    def telemetry(self) -> HttpTelemetry:
        """The state now."""
        with self._lock:
            now = self._advance(time.monotonic())
            hears = self._last_heartbeat is not None and not self._silent(now)
            return HttpTelemetry(self.robot_id, self._lat, self._lon, speed=self._speed_now(),
                                 battery=100.0, mode=self._mode, failsafe=self._in_failsafe,
                                 controller=hears)

    def command(self, body: bytes) -> tuple[int, UgvAck]:
        """(HTTP status, ack) for a command body."""
        ident = command_id_of(body) or "-"
        with self._lock:
            if ident in self._answered:
                return self._answered[ident]
            try:
                cmd = parse_command(body, COMMAND_PATH)
            except DecodeError as exc:
                return 400, UgvAck(ident, "rejected", str(exc))
            self._advance(time.monotonic())
            self._in_failsafe = False  # commanded again: the controller has taken over
            if cmd.cmd == "goto" and cmd.lat is not None and cmd.lon is not None:
                self._target, self._mode, status = (cmd.lat, cmd.lon), "goto", "accepted"
            elif cmd.cmd == "return_to_base":
                self._target, self._mode, status = self.home, "return", "accepted"
            elif cmd.cmd == "stop":
                self._target, self._mode, status = None, "idle", "done"
            else:
                return 400, UgvAck(ident, "rejected", f"{cmd.cmd} is not supported")
            answer = (200, UgvAck(ident, status))
            self.commands.append(json.loads(body))
            self._answered[ident] = answer
            while len(self._answered) > MAX_REMEMBERED_IDS:
                self._answered.popitem(last=False)
            return answer

    def heartbeat(self, body: bytes) -> None:
        """A controller heartbeat (DecodeError if malformed); it may set the failsafe."""
        beat = parse_heartbeat(body, HEARTBEAT_PATH)
        with self._lock:
            self._advance(time.monotonic())
            if beat.failsafe is not None:
                self.failsafe = FailsafePolicy(beat.failsafe, beat.timeout or
                                               (self.failsafe.timeout_s if self.failsafe
                                                else 5.0))
            self._last_heartbeat = time.monotonic()
            self.heartbeats += 1

    def _silent(self, now: float) -> bool:
        last = self._last_heartbeat
        return self.failsafe is not None and last is not None \
            and now - last > self.failsafe.timeout_s

    def _advance(self, now: float) -> float:
        """Move up to `now`, taking the failsafe at its moment if the controller fell silent."""
        if self.failsafe is not None and self._last_heartbeat is not None \
                and not self._in_failsafe and self._silent(now):
            moment = self._last_heartbeat + self.failsafe.timeout_s
            self._drive(moment)
            self._in_failsafe = True
            self._last_heartbeat = None  # heard again only from the next heartbeat on
            if self.failsafe.action is FailsafeAction.RTL:
                self._target, self._mode = self.home, "return"
            else:
                self._target, self._mode = None, "idle"
        self._drive(now)
        return now

    def _drive(self, until: float) -> None:
        elapsed = max(0.0, until - self._clock)
        self._clock = max(self._clock, until)
        if self._target is None:
            return
        self._lat, self._lon = step_towards(self._lat, self._lon, *self._target,
                                            self.speed * elapsed)
        if distance_m(self._lat, self._lon, *self._target) < 0.01:
            self._target, self._mode = None, "idle"

    def _speed_now(self) -> float:
        return self.speed if self._target is not None else 0.0


class _Handler(BaseHTTPRequestHandler):
    """The HTTP side of one `SimHttpRobot` (`sim` is set by a subclass per robot)."""

    sim: SimHttpRobot
    protocol_version = "HTTP/1.1"

    def log_message(self, format: str, *args: Any) -> None:  # noqa: A002 - base signature
        pass  # quiet: the tests' output stays readable

    def do_GET(self) -> None:  # noqa: N802 - http.server's name
        if self._failing():
            return
        if self.path != TELEMETRY_PATH:
            self._answer(404, {"reason": f"no {self.path}"})
            return
        self._answer(200, json.loads(self.sim.telemetry().to_json()))

    def do_POST(self) -> None:  # noqa: N802 - http.server's name
        length = int(self.headers.get("Content-Length") or 0)
        body = self.rfile.read(min(length, MAX_BODY))
        if self._failing():
            return
        if self.path == COMMAND_PATH:
            status, ack = self.sim.command(body)
            self._answer(status, json.loads(ack.to_json()))
        elif self.path == HEARTBEAT_PATH:
            try:
                self.sim.heartbeat(body)
            except DecodeError as exc:
                self._answer(400, {"reason": str(exc)})
                return
            self._answer(204, None)
        else:
            self._answer(404, {"reason": f"no {self.path}"})

    def _failing(self) -> bool:
        status = self.sim._fail_status
        if status is not None:
            self._answer(status, {"reason": "simulated failure"})
        return status is not None

    def _answer(self, status: int, body: dict[str, Any] | None) -> None:
        payload = json.dumps(body).encode() if body is not None else b""
        self.send_response(status)
        if payload:
            self.send_header("Content-Type", "application/json")
        self.send_header("Content-Length", str(len(payload)))
        self.end_headers()
        self.wfile.write(payload)
