"""JSON payloads map to literals by schema; anything else is a PayloadError naming the topic."""

from __future__ import annotations

import json
import math
from typing import Any

import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from mrss.agentspeak.literals import RESERVED
from mrss.edge import record_declarations
from mrss.edge.payloads import (
    CONVERTERS,
    Field,
    JsonMapping,
    PayloadError,
    decode_json,
    decode_json_object,
)

from .termcheck import read_literal

AREA = JsonMapping("area_goal_received", Field("area", "atom"), Field("priority", "int"),
                   Field("label", "string", default=""),
                   Field("position.lat", "lat", default=0.0))


def test_mapping_builds_the_literal_from_declared_fields() -> None:
    payload = json.dumps({"area": "a1", "priority": 3, "label": 'x"), evil(',
                          "position": {"lat": 43.5}}).encode()
    text = AREA.literal(payload, topic="ui/area")
    assert read_literal(text) == ("area_goal_received",
                                  [("atom", "a1"), 3, 'x"), evil(', 43.5], [])


def test_defaults_fill_missing_optional_fields() -> None:
    text = AREA.literal(b'{"area": "a2", "priority": 1}')
    assert text == 'area_goal_received(a2,1,"",0.0)'


@pytest.mark.parametrize(("payload", "reason"), [
    (b"\xff\xfe", "not UTF-8"),
    (b"{not json", "not JSON"),
    (b"[1, 2]", "not an object"),
    (b'{"priority": 1}', "missing field 'area'"),
    (b'{"area": "A1", "priority": 1}', "field 'area'"),
    (b'{"area": "a1", "priority": "high"}', "field 'priority'"),
    (b'{"area": "a1", "priority": true}', "field 'priority'"),
    (b'{"area": "a1", "priority": 1, "position": {"lat": 91}}', "outside"),
    (b'{"area": "a1", "priority": NaN}', "not JSON"),
    (b'{"area": "a1", "priority": 1, "label": 5}', "field 'label'"),
])
def test_bad_payloads_raise_payload_error_with_topic(payload: bytes, reason: str) -> None:
    with pytest.raises(PayloadError, match=reason) as info:
        AREA.literal(payload, topic="ui/area")
    assert info.value.topic == "ui/area"


def test_unknown_field_kind_is_refused_at_declaration() -> None:
    with pytest.raises(ValueError, match="unknown kind"):
        Field("x", "float128")


def test_decode_json_refuses_oversized_and_deep_payloads() -> None:
    with pytest.raises(PayloadError, match="exceeds"):
        decode_json(b"[" + b"0," * 600_000 + b"0]")
    with pytest.raises(PayloadError, match="not JSON"):
        decode_json(b"[" * 100_000 + b"]" * 100_000)
    assert decode_json_object(b'{"a": 1}') == {"a": 1}


json_values = st.recursive(
    st.none() | st.booleans() | st.integers() | st.floats(allow_nan=False) | st.text(),
    lambda inner: st.lists(inner, max_size=3) | st.dictionaries(st.text(max_size=8), inner,
                                                                 max_size=3),
    max_leaves=10,
)


@given(st.one_of(st.binary(max_size=200), json_values.map(lambda v: json.dumps(v).encode())))
def test_any_payload_gives_a_literal_or_a_payload_error(payload: bytes) -> None:
    try:
        text = AREA.literal(payload, topic="t")
    except PayloadError as exc:
        assert exc.topic == "t"
        return
    name, args, _ = read_literal(text)
    assert name == "area_goal_received" and len(args) == 4


def test_term_and_list_kinds_convert_nested_json() -> None:
    mapping = JsonMapping("seen", Field("ids", "list"), Field("extra", "term"),
                          Field("who", "symbol"))
    obj: dict[str, Any] = {"ids": ["a", 1, [2.5, True]], "extra": "E", "who": "Bob"}
    text = mapping.literal(json.dumps(obj).encode())
    assert read_literal(text)[1] == [["a", 1, [2.5, ("atom", "true")]], "E", "Bob"]
    with pytest.raises(PayloadError, match="dict"):
        mapping.literal(b'{"ids": [{"a": 1}], "extra": 1, "who": "x"}')


def test_a_reserved_word_is_refused_as_an_atom_and_says_so() -> None:
    mapping = JsonMapping("p", Field("v", "atom"))
    for word in ("if", "not", "while", "div"):
        with pytest.raises(PayloadError, match=f"'{word}' is a reserved word"):
            mapping.literal(json.dumps({"v": word}).encode(), topic="t")
    text = JsonMapping("p", Field("v", "symbol")).literal(b'{"v": "if"}', topic="t")
    assert read_literal(text)[1] == ["if"]  # a symbol field quotes it


# -- one property per field kind: what it declares is taken, nothing outside it ----------
FIELD_VALID: dict[str, st.SearchStrategy[Any]] = {
    # reserved words (`if`, `not`, ...) are no atoms: refused, see the test below
    "atom": st.from_regex(r"[a-z][a-zA-Z0-9_]{0,30}", fullmatch=True).filter(
        lambda text: text not in RESERVED),
    "robot": st.from_regex(r"[a-z][a-zA-Z0-9_]{0,30}", fullmatch=True).filter(
        lambda text: text not in RESERVED),           # no robots given: any atom
    "symbol": st.text(max_size=record_declarations.MAX_TEXT),
    "string": st.text(max_size=record_declarations.MAX_TEXT),
    "int": st.integers(-record_declarations.MAX_INT, record_declarations.MAX_INT),
    "number": st.floats(allow_nan=False, allow_infinity=False)
    | st.integers(-record_declarations.MAX_INT, record_declarations.MAX_INT),
    "lat": st.floats(-90.0, 90.0),
    "lon": st.floats(-180.0, 180.0),
    "bool": st.booleans(),
    "list": st.lists(st.integers(-1000, 1000) | st.text(max_size=10), max_size=20),
    "term": st.integers(-1000, 1000) | st.text(max_size=20) | st.lists(st.booleans()),
}
EXTREMES = st.one_of(
    st.integers(), st.floats(allow_nan=False), st.text(), st.none(), st.booleans(),
    st.just(2 ** 53 + 1), st.just(-(2 ** 60)), st.just(10 ** 300), st.just(1e308),
    st.just("x" * (record_declarations.MAX_TEXT + 1)), st.just({"a": 1}),
    st.just([[[[[[[[[[[[[[[[[[1]]]]]]]]]]]]]]]]]]), st.just(list(range(300))),
    st.lists(st.integers(), max_size=4))


def test_every_field_kind_has_a_property() -> None:
    assert set(FIELD_VALID) == set(CONVERTERS)


def _within(kind: str, value: Any) -> bool:
    """Whether a converted value keeps its kind's bounds (numbers finite, integers within
    +-2**53, latitudes and longitudes in range)."""
    if kind in ("int", "number", "lat", "lon"):
        bound = {"lat": 90.0, "lon": 180.0}.get(kind, math.inf)
        if isinstance(value, int):
            bound = min(bound, record_declarations.MAX_INT)
        return not isinstance(value, bool) and math.isfinite(value) and abs(value) <= bound
    if kind in ("string", "symbol", "atom", "robot") or isinstance(value, str):
        return len(str(value)) <= record_declarations.MAX_TEXT
    if kind in ("list", "term") and isinstance(value, list):
        return len(value) <= record_declarations.MAX_ITEMS \
            and all(_within("term", v) for v in value)
    if kind == "term" and isinstance(value, int | float) and not isinstance(value, bool):
        return _within("number", value)
    return True


@pytest.mark.parametrize("kind", sorted(CONVERTERS))
def test_a_field_takes_every_value_of_its_kind_and_bounds_the_rest(kind: str) -> None:
    mapping = JsonMapping("p", Field("v", kind))
    field = Field("v", kind)

    @settings(max_examples=40, deadline=None)
    @given(FIELD_VALID[kind])
    def valid(value: Any) -> None:
        text = mapping.literal(json.dumps({"v": value}).encode(), topic="t")
        name, args, _ = read_literal(text)
        assert name == "p" and len(args) == 1

    @settings(max_examples=60, deadline=None)
    @given(EXTREMES)
    def extreme(value: Any) -> None:
        try:
            converted = field.extract({"v": value})
        except ValueError:
            with pytest.raises(PayloadError):
                mapping.literal(json.dumps({"v": value}).encode(), topic="t")
            return
        assert _within(kind, converted), (kind, value, converted)

    valid()
    extreme()


def test_a_robot_field_names_one_of_the_robots_given() -> None:
    teleop = JsonMapping("teleop", Field("robot", "robot"), Field("on", "bool"))
    robots = frozenset({"uav1", "ugv1"})
    assert teleop.literal(b'{"robot": "ugv1", "on": true}', robots=robots) == "teleop(ugv1,true)"
    with pytest.raises(PayloadError, match=r"field 'robot': unknown robot 'ghost7' "
                                           r"\(known: uav1, ugv1\)"):
        teleop.args({"robot": "ghost7", "on": True}, topic="t", robots=robots)
    with pytest.raises(PayloadError, match="not a lowercase identifier"):
        teleop.args({"robot": "Ghost", "on": True}, robots=robots)
    assert teleop.args({"robot": "ghost7", "on": True}) == ["ghost7", True]  # none given


@pytest.mark.parametrize("payload", [
    b'{"goal": "\\ud800"}', b'{"\\udfff": 1}', b'[["x\\uDC00y"]]', b'"\\ud83d"',
])
def test_a_lone_surrogate_is_no_text_and_refused(payload: bytes) -> None:
    with pytest.raises(PayloadError, match="not Unicode text: a lone surrogate"):
        decode_json(payload, topic="t")


def test_escaped_text_that_is_unicode_is_taken() -> None:
    assert decode_json(b'{"a": "\\ud83d\\ude00 \\u00e9 \\\\ud800"}') == {"a": "😀 é \\ud800"}
