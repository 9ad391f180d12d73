"""The JSON-over-HTTP protocol between a robot and its HTTP link: paths, bodies, URL.

The robot serves, under its base URL (``http://host:port[/prefix]``):

- ``POST /command``: a command body ``{"id": ..., "cmd": ..., <fields>}`` (the MQTT UGV
  protocol's, `mrss.links.ugv_protocol.UgvCommand`), answered 2xx with an ack
  ``{"id", "status", "reason"}`` (`UgvAck`); a refusal is a 2xx ack with status
  ``rejected``/``failed``/``cancelled``, or a non-2xx answer (its ack's reason, if any,
  says why). A repeated id is answered again, not done twice.
- ``GET /telemetry``: one sample, `HttpTelemetry` below.
- ``POST /heartbeat``: the controller's heartbeat (`UgvHeartbeat`, same semantics as the
  MQTT UGV's: ``{"ts", "failsafe"?, "timeout"?}``, 1 Hz while the controller lives).

Every parser raises DecodeError naming the path; nothing malformed gets through.
"""

from __future__ import annotations

import json
from dataclasses import asdict, dataclass
from typing import Any
from urllib.parse import urlsplit

from mrss.edge import record_declarations, validation
from mrss.errors import ConfigError, DecodeError

COMMAND_PATH = "/command"
TELEMETRY_PATH = "/telemetry"
HEARTBEAT_PATH = "/heartbeat"
MAX_MODE_LEN = 32


def http_url_problem(url: str) -> str | None:
    """Why `url` is not a robot's base URL ``http(s)://host[:port][/prefix]``, or None."""
    try:
        parts = urlsplit(url)
        port = parts.port
    except ValueError as exc:
        return f"not a valid URL {url!r}: {exc} (expected http://host:port)"
    if parts.scheme not in ("http", "https"):
        return f"an HTTP link's url must start with http:// or https://, not {url!r}"
    if not parts.hostname:
        return f"no host in URL {url!r} (expected http://host:port)"
    if parts.query or parts.fragment:
        return f"a robot's base URL has no query or fragment: {url!r}"
    del port
    return None


def base_url(url: str) -> str:
    """`url` without a trailing slash; ConfigError (key ``url``) if it is not one."""
    problem = http_url_problem(url)
    if problem:
        raise ConfigError(problem, key="url")
    return url.rstrip("/")


@dataclass(frozen=True)
class HttpTelemetry:
    """One telemetry sample of an HTTP robot; only the position is required."""

    id: str
    lat: float
    lon: float
    heading: float | None = None
    speed: float | None = None
    battery: float | None = None
    mode: str = ""
    failsafe: bool = False     # acting on its failsafe (until commanded again)
    controller: bool = True    # hears the controller's heartbeats now

    def to_json(self) -> bytes:
        return json.dumps({k: v for k, v in asdict(self).items() if v is not None}).encode()


def json_object(payload: bytes, path: str) -> dict[str, Any]:
    """A JSON object body; DecodeError naming `path` otherwise."""
    try:
        data = json.loads(payload.decode("utf-8"))
    except (UnicodeDecodeError, ValueError, RecursionError) as exc:
        raise DecodeError(f"not UTF-8 JSON: {exc}", topic=path) from None
    if not isinstance(data, dict):
        raise DecodeError("expected a JSON object", topic=path)
    return data


def _number(data: dict[str, Any], key: str, path: str, lo: float, hi: float,
            required: bool = True) -> float | None:
    if key not in data and not required:
        return None
    try:  # bounded before float(): a 400-digit integer is refused, never an OverflowError
        return float(validation.number(data.get(key), repr(key), record_declarations.Range(lo, hi)))
    except validation.Rejected as exc:
        raise DecodeError(str(exc)[:200], topic=path) from None


def _flag(data: dict[str, Any], key: str, path: str, default: bool) -> bool:
    value = data.get(key, default)
    if not isinstance(value, bool):
        raise DecodeError(f"{key!r} must be true or false, got {value!r}", topic=path)
    return value


def parse_telemetry(payload: bytes, robot_id: str) -> HttpTelemetry:
    """A telemetry sample of `robot_id`; DecodeError if malformed or another robot's."""
    path = TELEMETRY_PATH
    data = json_object(payload, path)
    ident = data.get("id")
    if ident != robot_id:
        raise DecodeError(f"telemetry of {ident!r}, expected {robot_id!r}", topic=path)
    mode = data.get("mode", "")
    if not isinstance(mode, str) or len(mode) > MAX_MODE_LEN:
        raise DecodeError(f"'mode' must be a string of at most {MAX_MODE_LEN} characters",
                          topic=path)
    lat = _number(data, "lat", path, -90, 90)
    lon = _number(data, "lon", path, -180, 180)
    assert lat is not None and lon is not None
    return HttpTelemetry(
        id=robot_id, lat=lat, lon=lon,
        heading=_number(data, "heading", path, 0, 360, required=False),
        speed=_number(data, "speed", path, 0, 1000, required=False),
        battery=_number(data, "battery", path, 0, 100, required=False),
        mode=mode, failsafe=_flag(data, "failsafe", path, False),
        controller=_flag(data, "controller", path, True))
