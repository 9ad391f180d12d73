"""The recorder's fast path (msgspec) writes what the exact path (the codec and the JSON
module) writes, takes every kind, and leaves to the exact path all it cannot vouch for."""

from __future__ import annotations

import dataclasses
import enum
import json
import math
import typing
from typing import Any

import msgpack
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from mrss.errors import DecodeError
from mrss.messages import KINDS, EventStatus, Message, Percept, RobotData, decode_raw, encode
from mrss.recording.transcode import _exact, envelope_of_json, transcode


def _sample_value(hint: Any) -> Any:
    if isinstance(hint, type) and issubclass(hint, enum.StrEnum):
        return list(hint)[-1]
    origin = typing.get_origin(hint)
    if origin is list:
        return []
    if origin is dict:
        return {}
    return {str: "x", int: 7, float: 2.5, bool: True}.get(hint, {"free": [1, 2.5, "x"]})


# Text fields that are a closed set without being typed as one (their kind's validate).
_VALID = {("percept", "op"): "remove", ("edge.report", "status"): list(EventStatus)[-1]}


def sample(cls: type[Message]) -> Message:
    """A message of kind `cls` with every field set (one value per type)."""
    hints = typing.get_type_hints(cls)
    return cls(**{f.name: _VALID.get((cls.kind, f.name), _sample_value(hints[f.name]))
                  for f in dataclasses.fields(cls)})  # type: ignore[arg-type]


def same_as_exact(topic: bytes, payload: bytes) -> tuple[bytes, Any] | None:
    """The fast path's result, checked against the exact path's."""
    fast = transcode(topic, payload)
    try:
        data, envelope = _exact(topic, payload)
    except DecodeError:
        assert fast is None, "the fast path took a message the codec refuses"
        return None
    if fast is not None:
        assert json.loads(fast[0]) == json.loads(data)
        assert fast[1] == envelope
    return fast


@pytest.mark.parametrize("kind", sorted(KINDS))
def test_every_kind_takes_the_fast_path_and_writes_the_exact_json(kind: str) -> None:
    message = sample(KINDS[kind])
    topic, payload = encode(message, src="rcl", inc=2, cred=b"\xc4proof")
    assert same_as_exact(topic, payload) is not None
    _, envelope = decode_raw(topic, payload)
    assert envelope.body == message


@pytest.mark.parametrize("kind", sorted(KINDS))
def test_every_kinds_recording_json_reads_back_into_the_exact_envelope(kind: str) -> None:
    topic, payload = encode(sample(KINDS[kind]), src="rcl", inc=2, cred=b"\xc4proof")
    data, envelope = _exact(topic, payload)
    assert envelope_of_json(topic.decode(), data) == envelope


@pytest.mark.parametrize("data", [
    pytest.param({"raw": b"\x01"}, id="bytes"),
    pytest.param({"x": math.nan}, id="nan"),
])
def test_recording_json_with_a_tag_is_left_to_the_exact_path(data: dict[str, Any]) -> None:
    topic, payload = encode(RobotData(robot="r", data=data), src="s")
    json_data, _ = _exact(topic, payload)
    assert envelope_of_json(topic.decode(), json_data) is None
    assert envelope_of_json("robot.other.data", _exact(*encode(
        RobotData(robot="r", data={}), src="s"))[0]) is None  # not its robot's topic


def test_an_int_stays_an_int_and_cred_is_base64_text() -> None:
    topic, payload = encode(RobotData(robot="r", data={"n": 3, "x": 3.0}), src="s",
                            cred=b"\x00\xff")
    found = same_as_exact(topic, payload)
    assert found is not None
    value = json.loads(found[0])
    assert value["cred"] == "AP8=" and type(value["body"]["data"]["n"]) is int


@pytest.mark.parametrize("change", [
    pytest.param(lambda env: env["body"]["data"].update(raw=b"\x01"), id="bytes"),
    pytest.param(lambda env: env["body"]["data"].update(x=math.nan), id="nan"),
    pytest.param(lambda env: env["body"]["data"].update(x=[math.inf]), id="inf"),
    pytest.param(lambda env: env.update(op="session-secret"), id="operator credential"),
    pytest.param(lambda env: env.update(replayed=True), id="replayed"),
])
def test_what_json_must_tag_or_drop_is_left_to_the_exact_path(
        change: typing.Callable[[dict[str, Any]], None]) -> None:
    topic, payload = encode(RobotData(robot="r", data={"lat": 1.0}), src="s")
    env = msgpack.unpackb(payload)
    change(env)
    payload = msgpack.packb(env, use_bin_type=True)
    if "replayed" in env:
        assert same_as_exact(topic, payload) is not None
        return
    assert transcode(topic, payload) is None
    data, _ = _exact(topic, payload)
    assert b"session-secret" not in data and b"NaN" not in data and b"Infinity" not in data


@pytest.mark.parametrize("topic, env_change", [
    (b"robot.other.data", None),  # not its robot's topic
    (b"\xff", None),  # not UTF-8
    (b"robot.r.data", ("v", 2)),
    (b"robot.r.data", ("kind", "no.such.kind")),
    (b"robot.r.data", ("extra", 1)),
    (b"robot.r.data", ("inc", True)),
    (b"robot.r.data", ("body", {"robot": "r"})),  # data missing
    (b"robot.r.data", ("body", {"robot": "r", "data": {1: 2}})),  # a key not text
])
def test_what_the_codec_refuses_the_fast_path_refuses(
        topic: bytes, env_change: tuple[str, Any] | None) -> None:
    _, payload = encode(RobotData(robot="r", data={"lat": 1.0}), src="s")
    if env_change is not None:
        env = msgpack.unpackb(payload)
        env[env_change[0]] = env_change[1]
        payload = msgpack.packb(env, use_bin_type=True)
    assert transcode(topic, payload) is None
    with pytest.raises(DecodeError):
        decode_raw(topic, payload)


def test_a_kinds_own_validation_holds_on_the_fast_path() -> None:
    topic, payload = encode(Percept(literal="p", op="add"), src="s")
    env = msgpack.unpackb(payload)
    env["body"]["op"] = "bogus"
    assert same_as_exact(topic, msgpack.packb(env, use_bin_type=True)) is None


_free = st.recursive(
    st.none() | st.booleans() | st.integers(-2**63, 2**64 - 1) | st.floats()
    | st.text(max_size=5) | st.binary(max_size=3),
    lambda inner: st.lists(inner, max_size=3) | st.dictionaries(
        st.text(max_size=3) | st.integers(0, 3), inner, max_size=3),
    max_leaves=8)


@settings(max_examples=150, deadline=None)
@given(data=st.dictionaries(st.text(max_size=4), _free, max_size=4))
def test_free_data_of_any_shape_is_written_as_the_exact_path_writes_it(
        data: dict[str, Any]) -> None:
    env = msgpack.unpackb(encode(RobotData(robot="r", data={}), src="s")[1])
    env["body"]["data"] = data
    same_as_exact(b"robot.r.data", msgpack.packb(env, use_bin_type=True))
