"""The JSON protocol between an MQTT ground robot and its link: topics and message schemas.

Topics under ``<prefix>/<robot id>/`` (default prefix ``mrss/robots``):
``cmd`` and ``heartbeat`` (link -> robot), ``telemetry`` and ``ack`` (robot -> link), and
``status`` (retained ``online``, last will ``offline``). Every parser raises DecodeError
naming the topic; nothing malformed gets through. Field lists are in docs/robots.md.

Failsafe (mrss.links.failsafe): the link publishes a heartbeat every second, optionally
carrying the failsafe it wants (``{"ts": ..., "failsafe": "rtl", "timeout": 5.0}``). A
robot that heard one and then none for the timeout acts on its failsafe and reports
``failsafe: true`` in its telemetry until it is commanded again; ``controller`` says
whether it hears heartbeats now.
"""

from __future__ import annotations

import json
from dataclasses import dataclass
from typing import Any

from mrss.edge import record_declarations, validation
from mrss.errors import DecodeError
from mrss.links.failsafe import MAX_TIMEOUT_S, MIN_TIMEOUT_S, FailsafeAction

DEFAULT_PREFIX = "mrss/robots"
ONLINE = "online"
OFFLINE = "offline"
COMMANDS = ("goto", "stop", "pump", "return_to_base", "teleop", "drive", "observe")
# what `observe` takes where the robot stands (a rover's instruments; the arm for
# spectrum and sample)
INSTRUMENTS = ("image", "spectrum", "radar", "sample")
ACK_STATUSES = ("accepted", "rejected", "done", "failed", "cancelled")
TERMINAL_STATUSES = frozenset({"rejected", "done", "failed", "cancelled"})
MODES = ("idle", "goto", "return", "teleop")
MAX_ID_LEN = 64
MAX_SPEED_MPS = 20.0


@dataclass(frozen=True)
class UgvTopics:
    """The MQTT topics of one ground robot (no `heartbeat` topic: no failsafe watch)."""

    cmd: str
    telemetry: str
    ack: str
    status: str
    heartbeat: str = ""

    @classmethod
    def for_robot(cls, robot_id: str, prefix: str = DEFAULT_PREFIX) -> UgvTopics:
        base = f"{prefix.rstrip('/')}/{robot_id}"
        return cls(f"{base}/cmd", f"{base}/telemetry", f"{base}/ack", f"{base}/status",
                   f"{base}/heartbeat")


@dataclass(frozen=True)
class UgvHeartbeat:
    """The controller's heartbeat; `failsafe`/`timeout`, when set, configure the robot's."""

    ts: float
    failsafe: FailsafeAction | None = None
    timeout: float | None = None

    def to_json(self) -> bytes:
        return json.dumps({k: v for k, v in _fields_of(self).items() if v is not None}).encode()


@dataclass(frozen=True)
class UgvCommand:
    """A validated command; fields not used by `cmd` are None."""

    cmd: str
    id: str | None = None
    lat: float | None = None
    lon: float | None = None
    on: bool | None = None
    litres: float | None = None
    speed: float | None = None
    heading: float | None = None
    instrument: str | None = None

    def to_json(self) -> bytes:
        return json.dumps({k: v for k, v in _fields_of(self).items() if v is not None}).encode()


@dataclass(frozen=True)
class UgvAck:
    """The robot's answer about one command id: accepted, then a terminal status."""

    id: str
    status: str
    reason: str = ""

    def to_json(self) -> bytes:
        return json.dumps(_fields_of(self)).encode()

    @property
    def terminal(self) -> bool:
        return self.status in TERMINAL_STATUSES


@dataclass(frozen=True)
class UgvTelemetry:
    """One telemetry sample of a ground robot."""

    id: str
    ts: float
    lat: float
    lon: float
    heading: float
    speed: float
    battery: float
    tank: float
    tank_capacity: float
    pumping: bool
    mode: str
    at_base: bool
    teleop: bool
    failsafe: bool = False     # acting on its failsafe (until commanded again)
    controller: bool = True    # hears the controller's heartbeats now

    def to_json(self) -> bytes:
        return json.dumps(_fields_of(self)).encode()


def _fields_of(message: Any) -> dict[str, Any]:
    """A message's fields by name: what `dataclasses.asdict` gives for these messages
    (every field a scalar), without its deep copy (a fleet's telemetry and heartbeats
    are encoded hundreds of times a second)."""
    return {name: getattr(message, name) for name in message.__dataclass_fields__}


def _object(payload: bytes, topic: str | None) -> dict[str, Any]:
    try:
        data = json.loads(payload.decode("utf-8"))
    except (UnicodeDecodeError, ValueError, RecursionError) as exc:
        raise DecodeError(f"not UTF-8 JSON: {exc}", topic=topic) from None
    if not isinstance(data, dict):
        raise DecodeError("expected a JSON object", topic=topic)
    return data


def _number(data: dict[str, Any], key: str, topic: str | None, lo: float, hi: float) -> float:
    value = data.get(key)
    if type(value) is float and lo <= value <= hi:  # the usual case (finite: within bounds)
        return value
    try:  # bounded before float(): a 400-digit integer is refused, never an OverflowError
        return float(validation.number(value, repr(key), record_declarations.Range(lo, hi)))
    except validation.Rejected as exc:
        raise DecodeError(str(exc)[:200], topic=topic) from None


def _flag(data: dict[str, Any], key: str, topic: str | None) -> bool:
    value = data.get(key)
    if not isinstance(value, bool):
        raise DecodeError(f"{key!r} must be true or false, got {value!r}", topic=topic)
    return value


def _ident(value: Any, key: str, topic: str | None) -> str:
    if not isinstance(value, str) or not 0 < len(value) <= MAX_ID_LEN:
        raise DecodeError(f"{key!r} must be a string of 1..{MAX_ID_LEN} characters", topic=topic)
    return value


def command_id_of(payload: bytes) -> str | None:
    """The id of a command payload if it has a usable one, even when the rest is bad."""
    try:
        data = _object(payload, None)
        return _ident(data.get("id"), "id", None)
    except DecodeError:
        return None


def parse_command(payload: bytes, topic: str | None = None) -> UgvCommand:
    """A command from a JSON payload; DecodeError if anything is missing or wrong."""
    data = _object(payload, topic)
    cmd = data.get("cmd")
    if cmd not in COMMANDS:
        raise DecodeError(f"unknown command {cmd!r}; known: {', '.join(COMMANDS)}", topic=topic)
    ident = _ident(data["id"], "id", topic) if "id" in data else None
    if cmd == "goto":
        return UgvCommand(cmd, ident, lat=_number(data, "lat", topic, -90, 90),
                          lon=_number(data, "lon", topic, -180, 180))
    if cmd == "pump":
        on = _flag(data, "on", topic)
        litres = _number(data, "litres", topic, 0.001, 1e6) if "litres" in data else None
        return UgvCommand(cmd, ident, on=on, litres=litres)
    if cmd == "teleop":
        return UgvCommand(cmd, ident, on=_flag(data, "on", topic))
    if cmd == "drive":
        return UgvCommand(cmd, ident, speed=_number(data, "speed", topic, 0, MAX_SPEED_MPS),
                          heading=_number(data, "heading", topic, 0, 360))
    if cmd == "observe":
        instrument = data.get("instrument")
        if instrument not in INSTRUMENTS:
            raise DecodeError(f"unknown instrument {instrument!r}; known: "
                              f"{', '.join(INSTRUMENTS)}", topic=topic)
        return UgvCommand(cmd, ident, instrument=str(instrument))
    return UgvCommand(str(cmd), ident)


def parse_heartbeat(payload: bytes, topic: str | None = None) -> UgvHeartbeat:
    """A controller heartbeat; DecodeError if malformed (an unknown failsafe, a bad timeout)."""
    data = _object(payload, topic)
    ts = _number(data, "ts", topic, 0, 1e11)
    action: FailsafeAction | None = None
    if "failsafe" in data:
        try:
            action = FailsafeAction(data["failsafe"])
        except ValueError:
            known = ", ".join(a.value for a in FailsafeAction)
            raise DecodeError(f"unknown failsafe {data['failsafe']!r}; known: {known}",
                              topic=topic) from None
    timeout = _number(data, "timeout", topic, MIN_TIMEOUT_S, MAX_TIMEOUT_S) \
        if "timeout" in data else None
    return UgvHeartbeat(ts, action, timeout)


def _optional_flag(data: dict[str, Any], key: str, topic: str | None, default: bool) -> bool:
    return _flag(data, key, topic) if key in data else default


def parse_ack(payload: bytes, topic: str | None = None) -> UgvAck:
    """An ack from a JSON payload; DecodeError if malformed."""
    data = _object(payload, topic)
    status = data.get("status")
    if status not in ACK_STATUSES:
        raise DecodeError(f"unknown ack status {status!r}", topic=topic)
    reason = data.get("reason", "")
    if not isinstance(reason, str):
        raise DecodeError("'reason' must be a string", topic=topic)
    return UgvAck(_ident(data.get("id"), "id", topic), str(status), reason[:200])


def parse_telemetry(payload: bytes, robot_id: str, topic: str | None = None) -> UgvTelemetry:
    """A telemetry sample of robot `robot_id`; DecodeError if malformed or another robot's."""
    data = _object(payload, topic)
    ident = _ident(data.get("id"), "id", topic)
    if ident != robot_id:
        raise DecodeError(f"telemetry of {ident!r} on the topic of {robot_id!r}", topic=topic)
    mode = data.get("mode")
    if mode not in MODES:
        raise DecodeError(f"unknown mode {mode!r}", topic=topic)
    capacity = _number(data, "tank_capacity", topic, 0, 1e6)
    return UgvTelemetry(
        id=ident, ts=_number(data, "ts", topic, 0, 1e11),
        lat=_number(data, "lat", topic, -90, 90), lon=_number(data, "lon", topic, -180, 180),
        heading=_number(data, "heading", topic, 0, 360),
        speed=_number(data, "speed", topic, 0, MAX_SPEED_MPS),
        battery=_number(data, "battery", topic, 0, 100),
        tank=_number(data, "tank", topic, 0, capacity), tank_capacity=capacity,
        pumping=_flag(data, "pumping", topic), mode=str(mode),
        at_base=_flag(data, "at_base", topic), teleop=_flag(data, "teleop", topic),
        failsafe=_optional_flag(data, "failsafe", topic, False),
        controller=_optional_flag(data, "controller", topic, True),
    )
