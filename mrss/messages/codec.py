"""The wire: the envelope, ids, and the codec of bus messages.

A bus message is two frames, `[topic, msgpack(envelope)]`, where the envelope is
`{v, id, ts, src, inc, kind, body}`: schema version, message id, send time, sending
component, the sender's incarnation (so a dead incarnation's late messages can be
dropped), message kind, and the kind's fields. Three keys are optional and absent unless
set: `cred`, the sender's proof of its incarnation (mrss/messages/credentials.py), `op`,
the session credential of the operator who sent a command (mrss/auth/sessions.py), and
`replayed: true`, set by `mrss replay` on everything it sends (`mark_replayed`), so that
no component takes a recording for live traffic. `decode` validates all of it and raises
`DecodeError` with the reason for anything else; it never raises anything but that.
"""

from __future__ import annotations

import dataclasses
import enum
import itertools
import threading
import time
import types
import typing
import uuid as uuidlib
from dataclasses import dataclass
from typing import Any, Union

import msgpack

from mrss.errors import DecodeError
from mrss.messages.kinds import KINDS, SCHEMA_VERSION, Message


@dataclass(frozen=True)
class Envelope:
    """A decoded bus message: header fields plus the validated body."""

    topic: str
    id: str
    ts: float
    src: str
    inc: int
    body: Message
    v: int = SCHEMA_VERSION
    cred: bytes = b""  # the sender's proof of (src, inc); b"": none
    replayed: bool = False  # sent by `mrss replay`: a recording, not live traffic
    op: str = ""  # an operator's session credential (mrss.auth.sessions); "": none

    @property
    def kind(self) -> str:
        return self.body.kind


def new_id() -> str:
    """A fresh message or action id."""
    return uuidlib.uuid4().hex


class IdGenerator:
    """Cheap unique message ids: a random per-instance prefix plus a counter.

    A uuid4 per message costs a system call; a publisher sending thousands of messages a
    second uses one of these instead. Ids stay unique across processes (64 random bits).
    """

    def __init__(self) -> None:
        self._prefix = uuidlib.uuid4().hex[:16]
        self._count = itertools.count()

    def __call__(self) -> str:
        return f"{self._prefix}{next(self._count):x}"


def encode(
    body: Message, *, src: str, inc: int = 0, msg_id: str | None = None,
    topic: str | None = None, cred: bytes = b"", op: str = "",
) -> tuple[bytes, bytes]:
    """The two frames of `body` as sent on the bus: topic and msgpack envelope."""
    env = {
        "v": SCHEMA_VERSION,
        "id": msg_id or new_id(),
        "ts": time.time(),
        "src": src,
        "inc": inc,
        "kind": body.kind,
        "body": _body_dict(body),
    }
    if cred:
        env["cred"] = cred
    if op:
        env["op"] = op
    packer = getattr(_PACKERS, "packer", None)
    if packer is None:
        packer = _PACKERS.packer = msgpack.Packer(use_bin_type=True)
    return (topic or body.topic()).encode(), packer.pack(env)


# One msgpack Packer per thread: cheaper than a new one for every message.
_PACKERS = threading.local()


def _body_dict(body: Message) -> dict[str, Any]:
    fields: dict[str, Any] | None = getattr(body, "__dict__", None)
    if fields is not None and len(fields) == len(_schema(type(body)).names):
        return fields  # a dataclass instance's own map: exactly its fields, in order
    return {name: getattr(body, name) for name in _schema(type(body)).names}


def mark_replayed(payload: bytes) -> bytes:
    """The envelope `payload` flagged as replayed (`replayed: true`); anything that is not
    an envelope map is returned as it is (no receiver decodes it anyway)."""
    try:
        env = msgpack.unpackb(payload, raw=False, strict_map_key=False)
    except Exception:  # garbage stays garbage
        return payload
    if type(env) is not dict:
        return payload
    env["replayed"] = True
    return bytes(msgpack.packb(env, use_bin_type=True))


# The envelope's keys and the exact types each may have (bool is not an int here).
_ENVELOPE_FIELDS: dict[str, tuple[type, ...]] = {
    "v": (int,), "id": (str,), "ts": (float, int), "src": (str,), "inc": (int,),
    "kind": (str,), "body": (dict,),
}
# The optional keys, absent unless set, and their types.
_OPTIONAL_FIELDS: dict[str, tuple[type, ...]] = {"cred": (bytes,), "replayed": (bool,),
                                                 "op": (str,)}
_REQUIRED = len(_ENVELOPE_FIELDS)


def decode(topic: bytes, payload: bytes | bytearray | memoryview) -> Envelope:
    """Validate and decode one bus message; anything malformed raises DecodeError."""
    return decode_raw(topic, payload)[1]


def decode_raw(topic: bytes, payload: bytes | bytearray | memoryview
               ) -> tuple[dict[str, Any], Envelope]:
    """`decode`, also giving the envelope map as unpacked (for a recorder that writes the
    message as it came, without unpacking it twice)."""
    try:
        topic_text = bytes(topic).decode("utf-8")
    except UnicodeDecodeError as exc:
        raise DecodeError("topic is not UTF-8") from exc
    try:
        env = msgpack.unpackb(payload, raw=False, strict_map_key=True, ext_hook=_no_ext)
    except DecodeError as exc:
        raise DecodeError(exc.reason, topic=topic_text) from None
    except UnicodeDecodeError as exc:
        raise DecodeError("a string is not UTF-8", topic=topic_text) from exc
    except Exception as exc:  # msgpack raises many types for garbage input
        raise DecodeError(f"not msgpack: {exc.__class__.__name__}", topic=topic_text) from exc
    try:
        return env, _envelope(topic_text, env)
    except DecodeError as exc:
        raise DecodeError(exc.reason, topic=topic_text) from None
    except RecursionError:
        raise DecodeError("message nested too deeply", topic=topic_text) from None


def _no_ext(code: int, data: bytes) -> Any:
    raise DecodeError(f"msgpack extension type {code} is not allowed")


def _envelope(topic: str, env: Any) -> Envelope:
    if type(env) is not dict:
        raise DecodeError("envelope is not a map")
    try:
        version, kind, ts = env["v"], env["kind"], env["ts"]
        well_typed = (
            type(version) is int
            and type(env["id"]) is str and (type(ts) is float or type(ts) is int)
            and type(env["src"]) is str and type(env["inc"]) is int and type(kind) is str
            and type(env["body"]) is dict
        )
    except KeyError:
        well_typed = False
    cred, replayed, op = b"", False, ""
    if len(env) != _REQUIRED and well_typed:  # optional keys: checked only when present
        cred, replayed = env.get("cred", b""), env.get("replayed", False)
        op = env.get("op", "")
        well_typed = len(env) == _REQUIRED + ("cred" in env) + ("replayed" in env) \
            + ("op" in env) and type(cred) is bytes and type(replayed) is bool \
            and type(op) is str
    if not well_typed:
        _envelope_fault(env)
    if version != SCHEMA_VERSION:
        raise DecodeError(f"schema version {version} is not {SCHEMA_VERSION}")
    cls = KINDS.get(kind)
    if cls is None:
        raise DecodeError(f"unknown kind {kind!r}")
    body = build(cls, env["body"])
    expected = body.topic()
    if topic != expected and not topic.startswith(expected + "."):
        raise DecodeError(f"kind {cls.kind!r} does not belong on this topic")
    # Validated above; fill the frozen dataclass directly (its __init__ costs twice as much).
    result: Envelope = object.__new__(Envelope)
    result.__dict__.update(topic=topic, id=env["id"], ts=float(env["ts"]), src=env["src"],
                           inc=env["inc"], body=body, v=SCHEMA_VERSION, cred=cred,
                           replayed=replayed, op=op)
    return result


def _envelope_fault(env: dict[Any, Any]) -> typing.NoReturn:
    """Raise DecodeError naming what is wrong with an envelope's keys or types."""
    extra = sorted(map(str, set(env) - set(_ENVELOPE_FIELDS) - set(_OPTIONAL_FIELDS)))
    if extra:
        raise DecodeError(f"envelope has unknown key(s) {extra}")
    for key, types_ in _ENVELOPE_FIELDS.items():
        if key not in env:
            raise DecodeError(f"envelope lacks {key!r}")
        if type(env[key]) not in types_:
            raise DecodeError(f"envelope {key!r} has type {type(env[key]).__name__}")
    for key, types_ in _OPTIONAL_FIELDS.items():
        if key in env and type(env[key]) not in types_:
            raise DecodeError(f"envelope {key!r} has type {type(env[key]).__name__}")
    raise AssertionError("envelope fault not found")  # pragma: no cover


_M = typing.TypeVar("_M", bound=Message)


def build(cls: type[_M], fields: dict[str, Any]) -> _M:
    """Build and validate a message of type `cls` from a field map (DecodeError if bad)."""
    schema = _schema(cls)
    if type(fields) is not dict:
        raise DecodeError(f"{cls.kind}: body is not a map")
    checks = schema.checks
    for name, value in fields.items():
        check = checks.get(name)
        if check is None:
            extra = sorted(map(str, set(fields) - set(checks)))
            raise DecodeError(f"{cls.kind}: unknown field(s) {extra}")
        if not check(value):
            raise DecodeError(f"{cls.kind}: field {name!r} has type {type(value).__name__}")
    if len(fields) == len(checks) and schema.plain_init:
        # Every field present and type-checked: fill the frozen instance directly.
        msg: _M = object.__new__(cls)
        msg.__dict__.update(fields)
    else:
        for name in schema.required:
            if name not in fields:
                raise DecodeError(f"{cls.kind}: missing field {name!r}")
        msg = cls(**fields)
    msg.validate()
    return msg


Check = typing.Callable[[Any], bool]


@dataclass(frozen=True)
class _Schema:
    """A message class's field names, required fields and one type check per field."""

    names: tuple[str, ...]
    required: frozenset[str]
    checks: dict[str, Check]
    plain_init: bool  # __init__ only stores the fields (no __post_init__)


_SCHEMAS: dict[type, _Schema] = {}


def _schema(cls: type) -> _Schema:
    schema = _SCHEMAS.get(cls)
    if schema is None:
        hints = typing.get_type_hints(cls)
        fields = dataclasses.fields(cls)
        schema = _Schema(
            names=tuple(f.name for f in fields),
            required=frozenset(
                f.name for f in fields
                if f.default is dataclasses.MISSING and f.default_factory is dataclasses.MISSING
            ),
            checks={f.name: _checker(hints[f.name]) for f in fields},
            plain_init=not hasattr(cls, "__post_init__"),
        )
        _SCHEMAS[cls] = schema
    return schema


def _checker(hint: Any) -> Check:
    """A fast type check for one field's type hint."""
    if hint is Any:
        return _plain
    if hint is bool:
        return lambda v: v is True or v is False
    if hint is int:
        return lambda v: type(v) is int
    if hint is float:
        return lambda v: type(v) is float or type(v) is int
    if hint is str:
        return lambda v: type(v) is str
    if isinstance(hint, type) and issubclass(hint, enum.StrEnum):
        # any string: the kind's __post_init__ makes it the member, its validate refuses
        # a value outside the set with the value named
        return lambda v: isinstance(v, str)
    if hint is type(None):
        return lambda v: v is None
    origin = typing.get_origin(hint)
    if origin in (Union, types.UnionType):
        alternatives = [_checker(h) for h in typing.get_args(hint)]
        return lambda v: any(check(v) for check in alternatives)
    if origin is list:
        (item_hint,) = typing.get_args(hint)
        item = _checker(item_hint)
        return lambda v: type(v) is list and all(item(x) for x in v)
    if origin is dict:
        key_hint, value_hint = typing.get_args(hint)
        if key_hint is str and value_hint is Any:
            return _plain_map
        key, value = _checker(key_hint), _checker(value_hint)
        return lambda v: type(v) is dict and all(key(k) and value(x) for k, x in v.items())
    raise TypeError(f"no bus type check for {hint!r}")


_SCALARS = frozenset({str, int, float, bool, bytes, type(None)})


def _plain_map(value: Any) -> bool:
    """Whether `value` is a str-keyed map of plain data (the common telemetry shape)."""
    if type(value) is not dict:
        return False
    for k, v in value.items():
        if type(k) is not str or (type(v) not in _SCALARS and not _plain(v)):
            return False
    return True


def _plain(value: Any) -> bool:
    """Whether `value` is plain msgpack data: scalars, lists, str-keyed maps (no recursion)."""
    if type(value) in _SCALARS:
        return True
    stack = [value]
    while stack:
        item = stack.pop()
        kind = type(item)
        if kind is list:
            stack.extend(item)
        elif kind is dict:
            for k, v in item.items():
                if type(k) is not str:
                    return False
                stack.append(v)
        elif kind not in _SCALARS:
            return False
    return True
