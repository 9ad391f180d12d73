"""The simulated UGV: an MQTT ground robot with a battery and a water tank.

Run it as a process (``mrss sim ugv --broker mqtt://127.0.0.1:1883 --id ugv1``, or
``python -m mrss.sim.ugv``) or as a thread in tests (`SimUgv.start()` / `stop()`).
Commands arrive as JSON on ``<prefix>/<id>/cmd``; telemetry, answers and the retained
online/offline status (offline is also the last will) go out on ``telemetry``, ``ack``
and ``status``. A bad command is logged and ignored (answered "rejected" if it has an id).

The controller's heartbeats arrive on ``heartbeat``; with a failsafe (its own, or the one
a heartbeat asks for), the robot that heard one and then none for the timeout acts on
it (`UgvModel.lose_controller`), as ArduPilot's GCS failsafe does.
"""

from __future__ import annotations

import argparse
import logging
import os
import signal
import sys
import threading
import time
from collections import OrderedDict
from collections.abc import Mapping, Sequence
from types import FrameType
from typing import Any

from paho.mqtt import client as mqtt

from mrss.errors import ConfigError, DecodeError
from mrss.links.failsafe import DEFAULT_TIMEOUT_S, FailsafePolicy, parse_policy
from mrss.links.mqtt_url import disable_nagle, new_client, parse_broker_url, with_login
from mrss.links.ugv_protocol import (
    DEFAULT_PREFIX,
    OFFLINE,
    ONLINE,
    UgvAck,
    UgvTelemetry,
    UgvTopics,
    command_id_of,
    parse_command,
    parse_heartbeat,
)
from mrss.sim.controller_watch import ControllerWatch, WatchEvent
from mrss.sim.ugv_model import UgvModel, UgvParams

log = logging.getLogger("mrss.sim.ugv")

DEFAULT_BASE = (-35.36350, 149.16500)
MAX_PAYLOAD = 64 * 1024
REMEMBERED_IDS = 256
STEP_S = 0.05


class SimUgv:
    """One simulated ground robot connected to an MQTT broker."""

    def __init__(self, broker_url: str, robot_id: str = "ugv1", *,
                 prefix: str = DEFAULT_PREFIX, base: tuple[float, float] = DEFAULT_BASE,
                 params: UgvParams | None = None, speedup: float = 1.0,
                 telemetry_hz: float = 2.0, keepalive: int = 5,
                 failsafe: FailsafePolicy | None = None,
                 login: Mapping[str, str] | None = None) -> None:
        """`login`: the robot's own MQTT login and TLS files (`username`, `password_file`,
        `ca_certs`, `certfile`, `keyfile`: mrss.links.mqtt_url.with_login)."""
        if speedup <= 0 or telemetry_hz <= 0:
            raise ValueError("speedup and telemetry rate must be positive")
        self.address = with_login(parse_broker_url(broker_url), **(login or {}))
        self.robot_id = robot_id
        self.topics = UgvTopics.for_robot(robot_id, prefix)
        self.model = UgvModel(robot_id, base[0], base[1], params or UgvParams())
        self.speedup = speedup
        self.telemetry_period = 1.0 / telemetry_hz
        self.keepalive = keepalive
        self.bad_commands = 0
        self.failsafe = failsafe
        self.watch = ControllerWatch(failsafe.timeout_s if failsafe else DEFAULT_TIMEOUT_S)
        self._lock = threading.Lock()
        self._stop = threading.Event()
        self._thread: threading.Thread | None = None
        self._answered: OrderedDict[str, UgvAck] = OrderedDict()
        self._last = self._next_telemetry = 0.0
        self._threaded = False  # paho's network thread runs (else the caller's loop)
        self._client = new_client(f"mrss-sim-{robot_id}-{os.getpid()}-{id(self):x}",
                                  self.address)
        self._client.will_set(self.topics.status, OFFLINE, qos=1, retain=True)
        self._client.on_connect = self._on_connect
        self._client.on_message = self._on_message
        self._client.reconnect_delay_set(min_delay=1, max_delay=10)

    # -- life cycle ------------------------------------------------------------------------
    def start(self) -> None:
        """Run the robot on a background thread."""
        self._thread = threading.Thread(target=self.run, name=f"sim-ugv-{self.robot_id}",
                                        daemon=True)
        self._thread.start()

    def stop(self) -> None:
        """Stop: publish "offline", disconnect, end the thread."""
        self._stop.set()
        if self._thread is not None:
            self._thread.join(timeout=5)

    def snapshot(self) -> UgvTelemetry:
        """The robot's current state."""
        with self._lock:
            return self.model.telemetry(self.watch.present(time.monotonic()))

    def run(self) -> None:
        """Serve until `stop()`: take commands, drive, pump, publish telemetry."""
        client = self._client
        client.connect_async(self.address.host, self.address.port, keepalive=self.keepalive)
        client.loop_start()
        self._threaded = True
        self._log_start()
        self._last = self._next_telemetry = time.monotonic()
        try:
            while not self._stop.wait(STEP_S):
                self.tick(time.monotonic())
        finally:
            self.close()
            client.loop_stop()

    def _log_start(self) -> None:
        log.info("sim ugv %s on %s:%d, topics %s/*", self.robot_id, self.address.host,
                 self.address.port, self.topics.cmd.rsplit("/", 1)[0])

    @property
    def client(self) -> mqtt.Client:
        """The robot's MQTT client."""
        return self._client

    def connect(self) -> mqtt.Client:
        """Connect without a network thread: the caller's event loop (`mrss.sim.fleet`)
        then drives the returned client (`loop_read` when its socket is readable,
        `loop_write` while it `want_write`s, `loop_misc` every second) and calls `tick`."""
        client = self._client
        client.connect(self.address.host, self.address.port, keepalive=self.keepalive)
        self._log_start()
        self._last = self._next_telemetry = time.monotonic()
        return client

    def tick(self, now: float) -> None:
        """Drive and pump on to `now`; publish telemetry when due, and answers."""
        with self._lock:
            self._check_controller(now)
            self.model.step((now - self._last) * self.speedup)
            answers = self.model.take_answers()
            due = now >= self._next_telemetry or bool(answers)
            sample = self.model.telemetry(self.watch.present(now)) if due else None
        self._last = now
        if sample is not None:
            # Before the answers: a "done" is never newer than the last telemetry.
            if now >= self._next_telemetry:  # keep the rate, unless far behind
                self._next_telemetry += self.telemetry_period
                if self._next_telemetry <= now:
                    self._next_telemetry = now + self.telemetry_period
            self._client.publish(self.topics.telemetry, sample.to_json(), qos=0)
        self._publish_answers(answers)

    def close(self) -> None:
        """Publish "offline" (retained) and disconnect."""
        client = self._client
        info = client.publish(self.topics.status, OFFLINE, qos=1, retain=True)
        if client.is_connected() and self._threaded:
            info.wait_for_publish(timeout=2)
        client.disconnect()

    # -- MQTT callbacks (paho's network thread) --------------------------------------------
    def _on_connect(self, client: mqtt.Client, userdata: Any, flags: Any,
                    reason_code: Any, properties: Any) -> None:
        if reason_code.is_failure:
            log.warning("broker refused the connection: %s", reason_code)
            return
        disable_nagle(client)
        client.subscribe(self.topics.cmd, qos=1)
        if self.topics.heartbeat:
            client.subscribe(self.topics.heartbeat, qos=0)
        client.publish(self.topics.status, ONLINE, qos=1, retain=True)
        log.info("connected to the broker; status online")

    def _on_message(self, client: mqtt.Client, userdata: Any, message: Any) -> None:
        try:
            if message.topic == self.topics.heartbeat:
                self._handle_heartbeat(bytes(message.payload), str(message.topic))
            else:
                self._handle_command(bytes(message.payload), str(message.topic))
        except Exception:  # a bug here must not stop the robot
            log.exception("error handling a message on %s", message.topic)

    # -- failsafe --------------------------------------------------------------------------
    def _handle_heartbeat(self, payload: bytes, topic: str) -> None:
        try:
            if len(payload) > MAX_PAYLOAD:
                raise DecodeError(f"payload of {len(payload)} bytes", topic=topic)
            beat = parse_heartbeat(payload, topic)
        except DecodeError as exc:
            self.bad_commands += 1
            log.warning("bad controller heartbeat ignored: %s", exc)
            return
        with self._lock:
            if beat.failsafe is not None:  # the controller configures the failsafe
                policy = FailsafePolicy(beat.failsafe, beat.timeout or DEFAULT_TIMEOUT_S)
                if policy != self.failsafe:
                    log.info("failsafe set by the controller: %s", policy.describe())
                    self.failsafe = policy
                    self.watch.timeout_s = policy.timeout_s
            if not self.watch.heard_once and self.failsafe is not None:
                log.info("controller heard: failsafe %s", self.failsafe.describe())
            self.watch.heard(time.monotonic())

    def _check_controller(self, now: float) -> None:
        """Act on the failsafe when the controller's heartbeats stop (under the lock)."""
        policy = self.failsafe
        if policy is None:
            return
        event = self.watch.poll(now)
        if event is WatchEvent.LOST:
            why = f"no controller heartbeat for {policy.timeout_s:g} s"
            log.warning("failsafe (%s): %s", policy.action.value, why)
            self.model.lose_controller(policy.action, why)
        elif event is WatchEvent.REGAINED:
            log.info("controller heartbeats back; failsafe stays until commanded")

    def _handle_command(self, payload: bytes, topic: str) -> None:
        if len(payload) > MAX_PAYLOAD:
            self.bad_commands += 1
            log.warning("command on %s ignored: payload of %d bytes", topic, len(payload))
            return
        try:
            command = parse_command(payload, topic)
        except DecodeError as exc:
            self.bad_commands += 1
            log.warning("bad command ignored: %s", exc)
            ident = command_id_of(payload)
            if ident is not None:
                self._publish_answers([UgvAck(ident, "rejected", exc.reason)])
            return
        with self._lock:
            if command.id is not None and command.id in self._answered:
                answers = [self._answered[command.id]]  # a repeat: answer, do not redo
            else:
                self.model.apply(command)
                answers = self.model.take_answers()
        self._publish_answers(answers)

    def _publish_answers(self, answers: list[UgvAck]) -> None:
        for answer in answers:
            with self._lock:
                self._answered[answer.id] = answer
                self._answered.move_to_end(answer.id)
                while len(self._answered) > REMEMBERED_IDS:
                    self._answered.popitem(last=False)
            self._client.publish(self.topics.ack, answer.to_json(), qos=1)


# -- command line ----------------------------------------------------------------------------
def _base(text: str) -> tuple[float, float]:
    parts = text.split(",")
    if len(parts) != 2:
        raise argparse.ArgumentTypeError("expected LAT,LON")
    try:
        return float(parts[0]), float(parts[1])
    except ValueError as exc:
        raise argparse.ArgumentTypeError(str(exc)) from None


def configure(parser: argparse.ArgumentParser) -> None:
    """Add the simulated UGV's options to `parser`."""
    defaults = UgvParams()
    parser.add_argument("--broker", default="mqtt://127.0.0.1:1883", help="broker URL")
    parser.add_argument("--id", default="ugv1", help="robot id (default ugv1)")
    parser.add_argument("--prefix", default=DEFAULT_PREFIX,
                        help=f"topic prefix (default {DEFAULT_PREFIX})")
    parser.add_argument("--base", type=_base, default=DEFAULT_BASE,
                        help="base LAT,LON (write --base=LAT,LON when LAT is negative)")
    parser.add_argument("--speed", type=float, default=defaults.max_speed_mps,
                        help="top speed m/s")
    parser.add_argument("--tank", type=float, default=defaults.tank_capacity_l,
                        help="tank capacity in litres")
    parser.add_argument("--pump-rate", type=float, default=defaults.pump_rate_lps,
                        help="litres per second")
    parser.add_argument("--speedup", type=float, default=1.0,
                        help="simulated seconds per wall-clock second")
    parser.add_argument("--rate", type=float, default=2.0, help="telemetry messages per second")
    parser.add_argument("--keepalive", type=int, default=5, help="MQTT keepalive seconds")
    parser.add_argument("--failsafe", default=None,
                        help="without controller heartbeats: hold, rtl or stop (default: "
                             "none, unless the controller's heartbeat asks for one)")
    parser.add_argument("--failsafe-timeout", type=float, default=None,
                        help="seconds without controller heartbeats (default 5)")
    login = parser.add_argument_group("the robot's own MQTT login and TLS files")
    login.add_argument("--username", help="MQTT user name (replaces the URL's)")
    login.add_argument("--password-file", help="a file with the password on its first line")
    login.add_argument("--ca-certs", help="the CA of the broker's certificate (TLS on)")
    login.add_argument("--certfile", help="a TLS client certificate (PEM)")
    login.add_argument("--keyfile", help="its private key (PEM)")


def run(args: argparse.Namespace) -> int:
    """Run the simulated UGV until SIGINT/SIGTERM; returns the exit code."""
    logging.basicConfig(level=logging.INFO, format="%(asctime)s %(name)s %(message)s")
    try:
        params = UgvParams(max_speed_mps=args.speed, tank_capacity_l=args.tank,
                           pump_rate_lps=args.pump_rate)
        failsafe = parse_policy(args.failsafe, args.failsafe_timeout,
                                keys=("--failsafe", "--failsafe-timeout"))
        login = {name: value for name in ("username", "password_file", "ca_certs",
                                          "certfile", "keyfile")
                 if (value := getattr(args, name)) is not None}
        ugv = SimUgv(args.broker, args.id, prefix=args.prefix, base=args.base, params=params,
                     speedup=args.speedup, telemetry_hz=args.rate, keepalive=args.keepalive,
                     failsafe=failsafe, login=login)
    except (ConfigError, ValueError) as exc:
        print(f"mrss sim ugv: {exc}", file=sys.stderr)
        return 2

    def stop(signum: int, frame: FrameType | None) -> None:
        ugv.stop()

    signal.signal(signal.SIGTERM, stop)
    signal.signal(signal.SIGINT, stop)
    ugv.run()
    return 0


def main(argv: Sequence[str] | None = None) -> int:
    """Entry point of ``python -m mrss.sim.ugv``."""
    parser = argparse.ArgumentParser(prog="mrss sim ugv", description=__doc__)
    configure(parser)
    return run(parser.parse_args(argv))


if __name__ == "__main__":
    sys.exit(main())
