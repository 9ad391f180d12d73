"""The bus message codec: round trips for every kind, and nothing but DecodeError on bad input."""

from __future__ import annotations

import dataclasses
import enum
import re
import typing
from typing import Any

import msgpack
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from mrss import messages as m
from mrss.errors import DecodeError
from mrss.messages.bid_reports import BidReport
from mrss.messages.credentials import MAX_RUN

# -- strategies --------------------------------------------------------------------------

_INT64 = st.integers(min_value=-(2**63), max_value=2**64 - 1)
_scalars = st.one_of(
    st.none(), st.booleans(), _INT64, st.floats(allow_nan=False), st.text(max_size=20),
    st.binary(max_size=20),
)
plain_values = st.recursive(
    _scalars,
    lambda inner: st.one_of(
        st.lists(inner, max_size=4), st.dictionaries(st.text(max_size=8), inner, max_size=4)
    ),
    max_leaves=12,
)
nonempty = st.text(min_size=1, max_size=20)

_maybe_number = st.one_of(st.none(), st.floats(allow_nan=False))
bid_reports = st.builds(
    lambda *a: BidReport(*a).to_wire(), nonempty,
    st.sampled_from(list(m.WaitReason)), _maybe_number, _maybe_number, _maybe_number,
    st.one_of(st.none(), _INT64), st.floats(allow_nan=False), st.booleans())

# Fields whose values `validate` constrains, per kind.
_CONSTRAINED: dict[tuple[str, str], st.SearchStrategy[Any]] = {
    ("percept", "literal"): st.text(min_size=1, max_size=20).filter(str.strip),
    ("percept", "op"): st.sampled_from(["add", "remove"]),
    ("action.request", "uuid"): nonempty,
    ("action.request", "name"): nonempty,
    ("action.status", "uuid"): nonempty,
    ("action.status", "state"): st.sampled_from([s.value for s in m.ActionState]),
    ("action.status", "cause"): st.sampled_from(["", *(c.value for c in m.FailureCause)]),
    ("action.status", "critical"): nonempty,  # deferring needs a section
    ("action.status", "critical_bound"): st.floats(min_value=0, allow_nan=False),
    ("action.status", "progress_bound"): st.floats(min_value=0, allow_infinity=False),
    ("action.allocation", "uuid"): nonempty,
    ("action.allocation", "bids"): st.lists(bid_reports, max_size=3),
    ("action.allocation", "near"): st.one_of(st.just([]), st.lists(
        st.floats(allow_nan=False), min_size=2, max_size=2)),
    ("action.control", "command"): st.sampled_from(m.CONTROL_COMMANDS),
    ("action.control", "target_kind"): st.sampled_from(m.CONTROL_TARGETS),
    ("action.control", "target"): nonempty,
    ("dl.request", "request_id"): nonempty,
    ("dl.request", "function"): nonempty,
    ("edge.report", "status"): st.sampled_from([s.value for s in m.EventStatus]),
    ("node.beat", "node"): nonempty,
    ("node.beat", "boot"): nonempty,
    ("node.beat", "run"): st.integers(min_value=0, max_value=MAX_RUN),
    ("agent.gave_up", "agent"): nonempty,
    ("agent.gave_up", "goal"): nonempty,
    ("question", "id"): nonempty,
    ("question.answer", "id"): nonempty,
    ("question.answer", "answer"): nonempty,
    ("question.answer", "by"): nonempty,
    ("question.answer", "request"): nonempty,
    ("fleet.stand_down", "ident"): nonempty,
}


def _for_hint(hint: Any) -> st.SearchStrategy[Any]:
    if hint is Any:
        return plain_values
    simple: dict[Any, st.SearchStrategy[Any]] = {
        str: st.text(max_size=20), int: _INT64, bool: st.booleans(),
        float: st.floats(allow_nan=False),
    }
    if hint in simple:
        return simple[hint]
    if isinstance(hint, type) and issubclass(hint, enum.Enum):  # a closed set: its values
        return st.sampled_from([member.value for member in hint])
    origin, args = typing.get_origin(hint), typing.get_args(hint)
    if origin is list:
        return st.lists(_for_hint(args[0]), max_size=4)
    if origin is dict:
        return st.dictionaries(_for_hint(args[0]), _for_hint(args[1]), max_size=4)
    raise AssertionError(f"no strategy for {hint!r}")


def body_of(cls: type[m.Message]) -> st.SearchStrategy[m.Message]:
    """Random valid messages of one kind, optional fields sometimes left at their default."""
    hints = typing.get_type_hints(cls)
    fields: dict[str, st.SearchStrategy[Any]] = {}
    for f in dataclasses.fields(cls):  # type: ignore[arg-type]
        fields[f.name] = _CONSTRAINED.get((cls.kind, f.name), _for_hint(hints[f.name]))
    return st.fixed_dictionaries(fields).map(lambda kw: cls(**kw))


any_body = st.sampled_from(sorted(m.KINDS.values(), key=lambda c: c.kind)).flatmap(body_of)


# -- round trips -------------------------------------------------------------------------

@pytest.mark.parametrize("kind", sorted(m.KINDS))
@settings(max_examples=60, deadline=None)
@given(data=st.data())
def test_every_kind_round_trips_through_the_codec(kind: str, data: st.DataObject) -> None:
    body = data.draw(body_of(m.KINDS[kind]))
    suffix = data.draw(st.one_of(st.none(), st.from_regex(r"\A[a-z0-9]{1,6}\Z")))
    topic = body.topic() + (f".{suffix}" if suffix else "")
    src = data.draw(st.text(max_size=10))
    inc = data.draw(st.integers(min_value=0, max_value=2**31))
    frames = m.encode(body, src=src, inc=inc, msg_id="id-1", topic=topic)
    env = m.decode(*frames)
    assert env.body == body
    assert (env.topic, env.id, env.src, env.inc, env.kind) == (topic, "id-1", src, inc, kind)


def test_ids_from_a_generator_are_unique_across_generators() -> None:
    a, b = m.IdGenerator(), m.IdGenerator()
    ids = {a() for _ in range(1000)} | {b() for _ in range(1000)}
    assert len(ids) == 2000


# -- garbage and near-valid input --------------------------------------------------------

def _decode_or_decode_error(topic: bytes, payload: bytes) -> m.Envelope | None:
    """decode must return an Envelope or raise DecodeError, never anything else."""
    try:
        env = m.decode(topic, payload)
    except DecodeError as exc:
        assert exc.reason
        return None
    # Whatever it accepts is a valid message that survives a second round trip.
    again = m.decode(*m.encode(env.body, src=env.src, inc=env.inc, msg_id=env.id,
                               topic=env.topic))
    assert again.body == env.body
    return env


@settings(max_examples=400, deadline=None)
@given(topic=st.binary(max_size=30), payload=st.binary(max_size=200))
def test_random_bytes_raise_only_decode_error(topic: bytes, payload: bytes) -> None:
    _decode_or_decode_error(topic, payload)


_MUTATIONS = ("drop", "extra", "retype", "rekind", "bad_utf8", "truncate", "flip")


@st.composite
def near_valid(draw: st.DrawFn) -> tuple[bytes, bytes]:
    """A valid message's frames after one or two random mutations."""
    body = draw(any_body)
    topic, payload = m.encode(body, src="src", inc=1, msg_id="x")
    env: dict[str, Any] = msgpack.unpackb(payload)
    use_bin_type = True
    for _ in range(draw(st.integers(1, 2))):
        mutation = draw(st.sampled_from(_MUTATIONS))
        target = draw(st.sampled_from(["envelope", "body"]))
        inner = env.get("body")
        mapping: dict[str, Any] = inner if target == "body" and isinstance(inner, dict) else env
        keys = sorted(mapping)
        if mutation == "drop" and keys:
            del mapping[draw(st.sampled_from(keys))]
        elif mutation == "extra":
            mapping[draw(st.text(max_size=6))] = draw(plain_values)
        elif mutation == "retype" and keys:
            mapping[draw(st.sampled_from(keys))] = draw(plain_values)
        elif mutation == "rekind":
            env["kind"] = draw(st.one_of(st.sampled_from(sorted(m.KINDS)), st.text(max_size=8)))
            topic = draw(st.one_of(st.just(topic), st.text(max_size=12).map(str.encode)))
        elif mutation == "bad_utf8" and keys:
            # Packed without the bin type, bytes become a msgpack str holding invalid UTF-8.
            mapping[draw(st.sampled_from(keys))] = b"\xff\xfe" + draw(st.binary(max_size=4))
            use_bin_type = False
            if draw(st.booleans()):
                topic = b"\xc3\x28" + topic
    wrapped: Any = env
    if draw(st.booleans()) and draw(st.booleans()):
        wrapped = {"v": 1, "body": env} if draw(st.booleans()) else [env]
    packed: bytes = msgpack.packb(wrapped, use_bin_type=use_bin_type)
    last = draw(st.sampled_from(_MUTATIONS))
    if last == "truncate" and packed:
        packed = packed[: draw(st.integers(0, len(packed) - 1))]
    elif last == "flip" and packed:
        i = draw(st.integers(0, len(packed) - 1))
        packed = packed[:i] + bytes([packed[i] ^ draw(st.integers(1, 255))]) + packed[i + 1:]
    return topic, packed


@pytest.mark.slow
@settings(max_examples=1500, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(frames=near_valid())
def test_near_valid_envelopes_raise_only_decode_error(frames: tuple[bytes, bytes]) -> None:
    _decode_or_decode_error(*frames)


# -- specific rejections, each with its reason -------------------------------------------

def _payload(**changes: Any) -> bytes:
    env: dict[str, Any] = {"v": 1, "id": "i", "ts": 1.0, "src": "s", "inc": 0,
                           "kind": "percept", "body": {"literal": "fire(a)"}}
    env.update(changes)
    return msgpack.packb({k: v for k, v in env.items() if v is not ...}, use_bin_type=True)


@pytest.mark.parametrize(("topic", "payload", "reason"), [
    (b"percept", _payload(extra=1), "unknown key"),
    (b"percept", _payload(inc=...), "lacks 'inc'"),
    (b"percept", _payload(inc=True), "'inc' has type bool"),
    (b"percept", _payload(v=2), "schema version 2"),
    (b"percept", _payload(kind="nope"), "unknown kind"),
    (b"percept", _payload(body={"literal": "a", "x": 1}), "unknown field"),
    (b"percept", _payload(body={}), "missing field 'literal'"),
    (b"percept", _payload(body={"literal": 3}), "'literal' has type int"),
    (b"percept", _payload(body={"literal": "a", "op": "toggle"}), "op must be"),
    (b"perceptual", _payload(), "does not belong on this topic"),
    (b"robot.x.state", _payload(), "does not belong on this topic"),
    (b"\xff", _payload(), "topic is not UTF-8"),
    (b"percept", b"\xc1", "not msgpack"),
    (b"percept", _payload(body={"literal": "a", "op": msgpack.ExtType(5, b"")}), "extension"),
    (b"dl.reply", _payload(kind="dl.reply", body={"request_id": "r", "ok": True,
                                                   "result": {1: 2}}), "not msgpack"),
    (b"dl.reply", b"\x91" * 5000 + b"\x90", "not msgpack"),
    (b"agent.gave_up.a", _payload(kind="agent.gave_up", body={
        "agent": "a", "goal": "g1", "reason": "tired"}),
     "unknown give-up reason 'tired' \\(one of budget_exhausted, no_applicable_plan"),
])
def test_malformed_messages_name_their_reason(topic: bytes, payload: bytes, reason: str) -> None:
    with pytest.raises(DecodeError, match=reason) as info:
        m.decode(topic, payload)
    if topic != b"\xff":
        assert info.value.topic == topic.decode()


def test_json_values_reject_non_string_keys_deep_inside() -> None:
    payload = _payload(kind="dl.reply", body={"request_id": "r", "ok": True,
                                               "result": [{"a": {b"k": 1}}]})
    with pytest.raises(DecodeError, match="'result' has type list"):
        m.decode(b"dl.reply", payload)


def test_a_message_on_a_dotted_subtopic_of_its_own_topic_is_accepted() -> None:
    env = m.decode(b"percept.uav1", _payload())
    assert env.body == m.Percept(literal="fire(a)")
    assert env.topic == "percept.uav1"


def test_a_string_that_is_not_utf8_is_named_as_such() -> None:
    payload = msgpack.packb({"v": 1, "id": b"\xff", "ts": 1.0, "src": "s", "inc": 0,
                             "kind": "percept", "body": {"literal": "a"}}, use_bin_type=False)
    with pytest.raises(DecodeError, match="string is not UTF-8"):
        m.decode(b"percept", payload)


def test_the_optional_envelope_keys_round_trip_and_are_absent_unless_set() -> None:
    body = m.Percept(literal="fire(a)")
    plain = m.decode(*m.encode(body, src="events", inc=1))
    assert (plain.cred, plain.replayed) == (b"", False)
    assert set(msgpack.unpackb(m.encode(body, src="events", inc=1)[1])) == {
        "v", "id", "ts", "src", "inc", "kind", "body"}  # the old wire, byte for byte
    topic, payload = m.encode(body, src="events", inc=1, cred=b"\x01" * 16)
    proven = m.decode(topic, payload)
    assert proven.cred == b"\x01" * 16 and not proven.replayed
    replayed = m.decode(topic, m.mark_replayed(payload))
    assert replayed.replayed and replayed.cred == proven.cred and replayed.body == body
    assert m.mark_replayed(b"\xc1 not msgpack") == b"\xc1 not msgpack"


def test_an_action_status_of_the_old_wire_without_progress_bound_still_decodes() -> None:
    old_body = {"uuid": "u1", "state": "running", "reason": "", "progress": {"waypoint": 2},
                "robot": "uav1", "cause": "", "repeat": False, "name": "cover", "goal": "a1"}
    env = {"v": m.SCHEMA_VERSION, "id": "id-1", "ts": 1.0, "src": "rcl", "inc": 1,
           "kind": "action.status", "body": old_body}  # as recorded before the field was
    got = m.decode(b"action.status", msgpack.packb(env, use_bin_type=True)).body
    assert isinstance(got, m.ActionStatus)
    assert (got.state, got.progress, got.progress_bound) == (m.ActionState.RUNNING,
                                                             {"waypoint": 2}, 0.0)
    bounded = m.ActionStatus(uuid="u1", state=m.ActionState.RUNNING, progress_bound=120.0)
    assert m.decode(*m.encode(bounded, src="rcl")).body.progress_bound == 120.0


@pytest.mark.parametrize("bound", [-1.0, float("nan")])
def test_a_negative_progress_bound_is_refused(bound: float) -> None:
    body = {"uuid": "u1", "state": "running", "progress_bound": bound}
    with pytest.raises(DecodeError, match="progress bound"):
        m.build(m.ActionStatus, body)


@pytest.mark.parametrize(("extra", "reason"), [
    ({"cred": "not bytes"}, "envelope 'cred' has type str"),
    ({"replayed": 1}, "envelope 'replayed' has type int"),
    ({"signed": True}, "envelope has unknown key(s) ['signed']"),
])
def test_a_bad_optional_envelope_key_is_named(extra: dict[str, Any], reason: str) -> None:
    topic, payload = m.encode(m.Percept(literal="fire(a)"), src="events", inc=1)
    env = {**msgpack.unpackb(payload), **extra}
    with pytest.raises(DecodeError, match=re.escape(reason)):
        m.decode(topic, msgpack.packb(env, use_bin_type=True))


def test_a_credential_proves_one_incarnation_of_one_sender_under_one_key(
        tmp_path: Any) -> None:
    key = m.IncarnationKey.create(tmp_path)
    assert (tmp_path / "incarnation.key").stat().st_mode & 0o777 == 0o600
    assert m.load_key(str(tmp_path / "incarnation.key")) == key
    cred = key.credential("rcl", 2)
    assert key.vouches("rcl", 2, cred)
    assert not key.vouches("rcl", 3, cred) and not key.vouches("reasoner", 2, cred)
    assert not key.vouches("rcl", 2, b"") and not key.vouches("rcl", 2, cred[:-1] + b"x")
    other = m.IncarnationKey.create(tmp_path)  # the next run: a new key
    assert not other.vouches("rcl", 2, cred)
    assert m.load_key(str(tmp_path / "incarnation.key")) == other


# -- the bids of an allocation -------------------------------------------------------------

def _allocation(**bid: Any) -> tuple[bytes, bytes]:
    body = m.TaskAllocation(uuid="t1", state=m.AllocationState.AWARDED, robot="uav1")
    frames = m.encode(body, src="rcl")
    env = msgpack.unpackb(frames[1], raw=False)
    env["body"]["bids"] = [{"robot": "uav1", **bid}]
    return frames[0], msgpack.packb(env, use_bin_type=True)


@pytest.mark.parametrize(("bid", "reason"), [
    ({"unfit": "tired"}, "bid report 0: unknown excuse 'tired' (one of 'busy', "),
    ({"finish_s": "soon"}, "bid report 0: finish_s is not a number"),
    ({"busy_priority": 1.5}, "bid report 0: busy_priority is not an integer"),
    ({"why": "because"}, "bid report 0 has unknown key(s) ['why']"),
    ({"robot": ""}, "bid report 0 names no robot"),
])
def test_an_allocation_with_a_malformed_bid_names_the_bid_and_its_key(
        bid: dict[str, Any], reason: str) -> None:
    with pytest.raises(DecodeError, match=re.escape(reason)):
        m.decode(*_allocation(**bid))


def test_an_allocation_of_the_previous_wire_without_bids_still_decodes() -> None:
    body = m.TaskAllocation(uuid="t1", state=m.AllocationState.WAITING,
                            wait=m.WaitReason.BUSY, why="uav1 busy with priority 5")
    frames = m.encode(body, src="rcl")
    env = msgpack.unpackb(frames[1], raw=False)
    for key in ("bids", "bidders", "evaluator", "capabilities", "near", "lost_from"):
        del env["body"][key]
    decoded = m.decode(frames[0], msgpack.packb(env, use_bin_type=True)).body
    assert decoded == body and decoded.bids == []


def test_a_bid_report_says_why_in_words_from_its_figures() -> None:
    report = BidReport
    assert report("uav3", finish_s=41.6, battery_after=71.2).describe() == \
        "uav3: finish in 42 s, 71 % battery after"
    assert report("uav1", m.WaitReason.BUSY, busy_priority=5, busy_done=0.4).describe() \
        == "uav1 busy with priority 5 (40% done)"
    assert report("uav2", m.WaitReason.BATTERY, battery_after=12.0, reserve=20.0).describe() \
        == "uav2 battery too low (12 % < reserve 20 %)"
    assert report("uav4", m.WaitReason.UNAVAILABLE).describe("link down") == \
        "uav4 unavailable: link down"
    assert report("uav5", finish_s=None, preempts=True, busy_priority=1).describe() == \
        "uav5: finish in unknown time, pre-empting priority 1"
