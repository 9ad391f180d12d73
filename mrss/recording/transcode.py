"""The recorder's fast path: a bus message to its recording JSON in one typed C pass.

`decode_raw` unpacks a message with msgpack and checks every field in Python, then the
JSON encoder walks it again: 70 % of the recorder's time (profiled, `mrss bench
record`). Here msgspec decodes the envelope straight into typed structs generated from
the message kinds (mrss/messages/kinds.py: the same fields, types, closed sets and
required fields, unknown fields refused), the kind's own `validate` and topic check run
on the message built from them, and msgspec writes the JSON.

It only vouches for what it writes as the same JSON value as the exact path
(`decode_raw` + `schemas.json_bytes`) does (keys may come in another order, text
unescaped; tests/recording/test_transcode.py compares them): anything else, whether wrong (bad
msgpack, unknown kind, a bad field) or merely unusual (bytes or NaN in free data, which
JSON must tag; an operator's credential, which is dropped; a wrong topic), gives None,
and the caller takes the exact path, which writes it or names what is wrong with it.

The other way, `envelope_of_json` reads a recording's JSON back into the envelope with
the same structs (the replay dashboard's tape); JSON that may hold a tag, or that does
not decode, is the exact path's (`mcap_reader.recorded_message`, then the codec).
"""

from __future__ import annotations

import base64
import dataclasses
import functools
import operator
import types
import typing
from collections.abc import Iterable
from typing import Annotated, Any, Literal, Union

import msgspec

from mrss.errors import DecodeError
from mrss.messages import KINDS, SCHEMA_VERSION, Envelope, Message, decode_raw
from mrss.recording.schemas import json_bytes

_MAX = 1.7976931348623157e308
# A float JSON can hold: msgspec refuses NaN and the infinities against these bounds.
_Finite = Annotated[float, msgspec.Meta(ge=-_MAX, le=_MAX)]
_Number = int | _Finite  # an int stays an int, as msgpack gave it
FREE_DEPTH = 8  # how deep free data (a field typed Any) may nest on the fast path


def _union(members: Iterable[Any]) -> Any:
    return functools.reduce(operator.or_, members)


def _json_type(depth: int) -> Any:
    """JSON data nested at most `depth` deep: scalars (no bytes, no NaN or infinity),
    lists and str-keyed maps of it. Free data deeper than that is the exact path's."""
    scalar = None | bool | int | _Finite | str
    if depth == 0:
        return scalar
    inner = _json_type(depth - 1)
    return scalar | list[inner] | dict[str, inner]  # type: ignore[valid-type]


_FREE = _json_type(FREE_DEPTH)


def _typed(hint: Any) -> Any:
    """The msgspec type of one field's type hint: free data (Any) as `_FREE`, a float
    as an int or a finite float, the rest as it is (str, int, bool, closed sets)."""
    if hint is Any:
        return _FREE
    if hint is float:
        return _Number
    origin = typing.get_origin(hint)
    if origin in (Union, types.UnionType):
        return _union(_typed(h) for h in typing.get_args(hint))
    if origin is list:
        return list[_typed(typing.get_args(hint)[0])]  # type: ignore[misc]
    if origin is dict:
        key_hint, value_hint = typing.get_args(hint)
        return dict[key_hint, _typed(value_hint)]  # type: ignore[misc,valid-type]
    return hint


@dataclasses.dataclass(frozen=True)
class _Kind:
    """A message kind as the fast path handles it."""

    cls: type[Message]
    plain_init: bool  # filled directly (no __post_init__), as the codec does


def _body_struct(cls: type[Message]) -> type[msgspec.Struct]:
    hints = typing.get_type_hints(cls)
    fields: list[Any] = []
    for f in dataclasses.fields(cls):  # type: ignore[arg-type]
        typed = _typed(hints[f.name])
        if f.default is not dataclasses.MISSING:
            fields.append((f.name, typed, f.default))
        elif f.default_factory is not dataclasses.MISSING:
            fields.append((f.name, typed, msgspec.field(default_factory=f.default_factory)))
        else:
            fields.append((f.name, typed))
    return msgspec.defstruct(f"{cls.__name__}Body", fields, forbid_unknown_fields=True)


def _envelope_struct(kind: str, body: type[msgspec.Struct]) -> type[msgspec.Struct]:
    """The envelope of `kind`, tagged by its `kind` key. No `op`: an envelope with an
    operator's credential is the exact path's (it drops it). `cred`, bytes, is written
    as base64 text, as the schema says."""
    return msgspec.defstruct(
        f"{body.__name__}Envelope",
        [("v", Literal[SCHEMA_VERSION]), ("id", str), ("ts", _Number), ("src", str),
         ("inc", int), ("body", body), ("cred", bytes, b""), ("replayed", bool, False)],
        tag_field="kind", tag=kind, forbid_unknown_fields=True, omit_defaults=True)


def _build() -> tuple[msgspec.msgpack.Decoder[Any], msgspec.json.Decoder[Any],
                      dict[type, _Kind]]:
    envelopes: list[Any] = []
    kinds: dict[type, _Kind] = {}
    for kind, cls in KINDS.items():
        envelope = _envelope_struct(kind, _body_struct(cls))
        envelopes.append(envelope)
        kinds[envelope] = _Kind(cls, not hasattr(cls, "__post_init__"))
    union = _union(envelopes)
    return msgspec.msgpack.Decoder(union), msgspec.json.Decoder(union), kinds


_DECODER, _JSON_DECODER, _KINDS = _build()
_ENCODE = msgspec.json.Encoder().encode
_asdict = msgspec.structs.asdict


def transcode(topic: bytes, payload: bytes) -> tuple[bytes, Envelope] | None:
    """The recording JSON of one bus message and its decoded envelope, or None when the
    exact path must decide (see the module's doc)."""
    try:
        env = _DECODER.decode(payload)
        topic_text = topic.decode()
    except (msgspec.DecodeError, UnicodeDecodeError):
        return None
    envelope = _envelope(env, topic_text)
    return None if envelope is None else (_ENCODE(env), envelope)


def envelope_of_json(topic: str, data: bytes) -> Envelope | None:
    """The envelope a recording's JSON of a bus message on `topic` holds, decoded and
    checked as `transcode` does (the other way), or None when the exact path must decide:
    JSON that a tag may be in (bytes, NaN: `$bytes`, `$float`), or that does not decode."""
    if b'"$bytes"' in data or b'"$float"' in data:
        return None
    try:
        env = _JSON_DECODER.decode(data)
    except msgspec.DecodeError:
        return None
    return _envelope(env, topic)


def _envelope(env: Any, topic_text: str) -> Envelope | None:
    """The message `env` (a generated envelope struct) holds, validated, on its topic."""
    kind = _KINDS[type(env)]
    fields = _asdict(env.body)
    try:
        if kind.plain_init:
            msg = object.__new__(kind.cls)
            msg.__dict__.update(fields)
        else:
            msg = kind.cls(**fields)
        msg.validate()
    except DecodeError:
        return None
    expected = msg.topic()
    if topic_text != expected and not topic_text.startswith(expected + "."):
        return None
    envelope: Envelope = object.__new__(Envelope)
    envelope.__dict__.update(topic=topic_text, id=env.id, ts=float(env.ts), src=env.src,
                             inc=env.inc, body=msg, v=SCHEMA_VERSION, cred=env.cred,
                             replayed=env.replayed, op="")
    return envelope


def recording_json(topic: bytes, payload: bytes) -> tuple[bytes, Envelope]:
    """One bus message as a recording writes it: its envelope in JSON, and decoded
    (DecodeError with the reason if it is not a valid bus message)."""
    return transcode(topic, payload) or _exact(topic, payload)


def _exact(topic: bytes, payload: bytes) -> tuple[bytes, Envelope]:
    """What `transcode` did not vouch for: decoded by the codec (DecodeError with the
    reason), written by the JSON module with bytes and non-finite floats tagged."""
    env, envelope = decode_raw(topic, payload)
    if "cred" in env or "op" in env:
        env = dict(env)
        env.pop("op", None)  # an operator's session credential is a secret: never kept
        if "cred" in env:  # base64 text, as the schema says (not a tagged object)
            env["cred"] = base64.b64encode(env["cred"]).decode("ascii")
    return json_bytes(env), envelope
