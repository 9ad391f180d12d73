"""JSON payloads map to literals by schema; anything else is a PayloadError naming the topic."""

from __future__ import annotations

import json
from typing import Any

import pytest
from hypothesis import given
from hypothesis import strategies as st

from mrss.edge.payloads import Field, JsonMapping, PayloadError, decode_json, decode_json_object

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
