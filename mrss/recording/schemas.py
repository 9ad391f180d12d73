"""The JSON schemas of an MCAP recording: one per MRSS message kind, and Foxglove's LocationFix.

Each bus message is stored as its envelope in JSON, `{v, id, ts, src, inc, kind, body}`
(plus `cred` and `replayed` when set), so any MCAP reader can decode it against the
channel's schema (`mrss.<kind>`, encoding `jsonschema`). The schemas are generated from
the message kinds' dataclasses (mrss/messages/kinds.py): a field's type hint gives its
JSON type, a closed set its `enum`, a field without a default is `required`.

JSON has no bytes and no NaN or infinity; msgpack has both. They are written as tagged
objects, `{"$bytes": "<base64>"}` and `{"$float": "nan" | "inf" | "-inf"}`, which only
appear where a kind's field is free data (JsonValue) or in `cred` (base64 text), and are
turned back on reading (`from_json`), so a replayed envelope is the recorded one.
"""

from __future__ import annotations

import base64
import dataclasses
import enum
import json
import math
import types
import typing
from typing import Any, Union

import msgspec

from mrss.messages import KINDS, Message

SCHEMA_PREFIX = "mrss."
MALFORMED_SCHEMA = "mrss.malformed"
LOCATION_FIX = "foxglove.LocationFix"
# The telemetry record type that is the robot's own position (docs/robots.md).
POSITION_RECORD = "position"
ENCODING = "jsonschema"
_DRAFT = "https://json-schema.org/draft/2020-12/schema"


def schema_name(kind: str) -> str:
    return SCHEMA_PREFIX + kind


def _type_schema(hint: Any) -> dict[str, Any]:
    """The JSON schema of one field's type hint (Any: any JSON value)."""
    if hint is Any:
        return {}
    if hint is bool:
        return {"type": "boolean"}
    if hint is int:
        return {"type": "integer"}
    if hint is float:
        return {"type": "number"}
    if hint is str:
        return {"type": "string"}
    if hint is type(None):
        return {"type": "null"}
    if isinstance(hint, type) and issubclass(hint, enum.StrEnum):
        return {"type": "string", "enum": [member.value for member in hint]}
    origin = typing.get_origin(hint)
    if origin in (Union, types.UnionType):
        return {"anyOf": [_type_schema(h) for h in typing.get_args(hint)]}
    if origin is list:
        (item,) = typing.get_args(hint)
        return {"type": "array", "items": _type_schema(item)}
    if origin is dict:
        _key, value = typing.get_args(hint)
        return {"type": "object", "additionalProperties": _type_schema(value)}
    raise TypeError(f"no JSON schema for {hint!r}")


def body_schema(cls: type[Message]) -> dict[str, Any]:
    """The JSON schema of a kind's body: its fields, their types, the required ones."""
    hints = typing.get_type_hints(cls)
    fields = dataclasses.fields(cls)  # type: ignore[arg-type]
    schema: dict[str, Any] = {
        "type": "object",
        "properties": {f.name: _type_schema(hints[f.name]) for f in fields},
        "additionalProperties": False,
    }
    required = [f.name for f in fields if f.default is dataclasses.MISSING
                and f.default_factory is dataclasses.MISSING]
    if required:
        schema["required"] = required
    return schema


def kind_schema(cls: type[Message]) -> dict[str, Any]:
    """The JSON schema of an envelope carrying a message of kind `cls.kind`."""
    doc = (cls.__doc__ or cls.kind).strip().split("\n\n")[0]
    return {
        "$schema": _DRAFT,
        "title": schema_name(cls.kind),
        "description": " ".join(doc.split()),
        "type": "object",
        "properties": {
            "v": {"type": "integer"},
            "id": {"type": "string"},
            "ts": {"type": "number", "description": "send time, Unix seconds"},
            "src": {"type": "string", "description": "the sending component"},
            "inc": {"type": "integer", "description": "the sender's incarnation"},
            "kind": {"const": cls.kind},
            "body": body_schema(cls),
            "cred": {"type": "string", "contentEncoding": "base64"},
            "replayed": {"type": "boolean"},
        },
        "required": ["v", "id", "ts", "src", "inc", "kind", "body"],
        "additionalProperties": False,
    }


def all_kind_schemas() -> dict[str, dict[str, Any]]:
    """Schema name -> schema, for every message kind."""
    return {schema_name(kind): kind_schema(cls) for kind, cls in KINDS.items()}


MALFORMED = {
    "$schema": _DRAFT,
    "title": MALFORMED_SCHEMA,
    "description": "A ZeroMQ message on the bus that did not decode as a bus message.",
    "type": "object",
    "properties": {
        "frames": {"type": "array",
                   "items": {"type": "string", "contentEncoding": "base64"}},
        "note": {"type": "string", "description": "why it did not decode"},
    },
    "required": ["frames", "note"],
    "additionalProperties": False,
}

# Foxglove's well-known schema (foxglove/schemas, jsonschema/LocationFix.json).
LOCATION_FIX_SCHEMA = {
    "title": LOCATION_FIX,
    "description": "A navigation satellite fix for any Global Navigation Satellite System",
    "type": "object",
    "properties": {
        "timestamp": {
            "type": "object", "title": "time",
            "properties": {"sec": {"type": "integer", "minimum": 0},
                           "nsec": {"type": "integer", "minimum": 0, "maximum": 999999999}},
        },
        "frame_id": {"type": "string"},
        "latitude": {"type": "number"},
        "longitude": {"type": "number"},
        "altitude": {"type": "number"},
        "position_covariance": {"type": "array", "items": {"type": "number"},
                                "minItems": 9, "maxItems": 9},
        "position_covariance_type": {"type": "integer", "enum": [0, 1, 2, 3]},
    },
}


class _Time(msgspec.Struct):
    sec: int
    nsec: int


class _LocationFix(msgspec.Struct):
    """`foxglove.LocationFix`, its fields in the schema's order."""

    timestamp: _Time
    frame_id: str
    latitude: float
    longitude: float
    altitude: float
    position_covariance: list[float]
    position_covariance_type: int


_NO_COVARIANCE = [0.0] * 9
_NUMBERS = (int, float)  # exactly: a bool is no coordinate
_encode_fix = msgspec.json.Encoder().encode


def _fix(robot: str, ts: float, data: dict[str, Any]) -> _LocationFix | None:
    kind = data.get("type")
    if kind is not None and kind != POSITION_RECORD:
        return None
    lat: Any = data.get("lat")
    lon: Any = data.get("lon")
    alt: Any = data.get("alt", 0.0)
    if not (type(lat) in _NUMBERS and type(lon) in _NUMBERS and type(alt) in _NUMBERS
            and math.isfinite(lat) and math.isfinite(lon) and math.isfinite(alt)):
        return None
    sec = int(ts)
    return _LocationFix(_Time(sec, min(int((ts - sec) * 1e9), 999_999_999)), robot,
                        float(lat), float(lon), float(alt), _NO_COVARIANCE, 0)


def location_fix(robot: str, ts: float, data: dict[str, Any]) -> dict[str, Any] | None:
    """A LocationFix of a robot's own position: a telemetry record of type `position`
    (or one without a type, a plain sample) with a numeric lat and lon. Records of other
    types carry the position of what they report (a `hotspot` the UAV saw), not the
    robot's, and make none."""
    fix = _fix(robot, ts, data)
    return None if fix is None else dict(msgspec.to_builtins(fix))


def location_fix_json(robot: str, ts: float, data: dict[str, Any]) -> bytes | None:
    """`location_fix` as compact JSON (a fix holds finite numbers and text: no tags)."""
    fix = _fix(robot, ts, data)
    return None if fix is None else _encode_fix(fix)


def to_json(value: Any) -> Any:
    """`value` (msgpack data) as JSON data: bytes and non-finite floats tagged."""
    kind = type(value)
    if kind is dict:
        return {k: to_json(v) for k, v in value.items()}
    if kind is list:
        return [to_json(v) for v in value]
    if kind is bytes:
        return {"$bytes": base64.b64encode(value).decode("ascii")}
    if kind is float and not math.isfinite(value):
        return {"$float": repr(value)}
    return value


def _tag_bytes(value: Any) -> Any:
    if type(value) is bytes:
        return {"$bytes": base64.b64encode(value).decode("ascii")}
    raise TypeError(f"{type(value).__name__} is not JSON")


# The C encoder does the common case; `default` tags bytes as `to_json` does.
_ENCODE = json.JSONEncoder(separators=(",", ":"), allow_nan=False, default=_tag_bytes).encode


def json_bytes(value: Any) -> bytes:
    """`value` (msgpack data) as compact JSON text, tagged as `to_json` tags it."""
    try:
        return _ENCODE(value).encode()
    except ValueError:  # a NaN or an infinity somewhere: the slow path tags it
        return json.dumps(to_json(value), separators=(",", ":")).encode()


def from_json(value: Any) -> Any:
    """The msgpack data `to_json` made `value` of."""
    kind = type(value)
    if kind is dict:
        if len(value) == 1:
            if type(value.get("$bytes")) is str:
                return base64.b64decode(value["$bytes"])
            if value.get("$float") in ("nan", "inf", "-inf"):
                return float(value["$float"])
        return {k: from_json(v) for k, v in value.items()}
    if kind is list:
        return [from_json(v) for v in value]
    return value
