"""Property tests of the validation layer (mrss.edge.validation): for every declared record
type, records inside the declaration pass and any field pushed outside it is refused with
`Rejected` (never another exception); the bounds on plain data; the rate-limited log."""

from __future__ import annotations

import logging
import math
from types import MappingProxyType
from typing import Any

import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from mrss.edge.record_declarations import (
    DEFAULT_LIMITS,
    LIMIT_NAMES,
    MAX_DEPTH,
    MAX_INT,
    MAX_ITEMS,
    MAX_TEXT,
    RECORDS,
    FieldKind,
    Limits,
    Range,
    RobotType,
    Spec,
    configured_robots,
)
from mrss.edge.rejections import MAX_COUNTED_KINDS, MAX_LOGGED_KINDS, RejectionLog
from mrss.edge.validation import (
    RecordValidator,
    Rejected,
    _fits,
    check_record,
    limit_overrides,
    plain,
)

AERIAL = DEFAULT_LIMITS[RobotType.AERIAL]


def bound_of(spec: Spec, limits: Limits) -> Range | None:
    return getattr(limits, spec.bound) if isinstance(spec.bound, str) else spec.bound


def valid_value(spec: Spec, limits: Limits) -> st.SearchStrategy[Any]:
    bound = bound_of(spec, limits)
    if spec.kind is FieldKind.NUMBER:
        assert bound is not None
        return st.floats(bound.low, bound.high, allow_nan=False)
    if spec.kind is FieldKind.INT:
        assert bound is not None
        return st.integers(int(bound.low), int(bound.high))
    if spec.kind is FieldKind.TEXT:
        return st.text(max_size=40)
    return st.booleans()


def invalid_value(spec: Spec, limits: Limits) -> st.SearchStrategy[Any]:
    bound = bound_of(spec, limits)
    bad: list[st.SearchStrategy[Any]] = [st.lists(st.integers(), min_size=1, max_size=2)]
    if spec.kind in (FieldKind.NUMBER, FieldKind.INT):
        assert bound is not None
        bad += [st.sampled_from([math.inf, -math.inf, math.nan, 10 ** 400, -(10 ** 400),
                                 True, "12"]),
                st.floats(min_value=bound.high, exclude_min=True, allow_nan=False,
                          allow_infinity=False).filter(lambda v: v > bound.high),
                st.floats(max_value=bound.low, exclude_max=True, allow_nan=False,
                          allow_infinity=False).filter(lambda v: v < bound.low)]
        if spec.kind is FieldKind.INT:
            bad.append(st.just(1.5))
    elif spec.kind is FieldKind.TEXT:
        bad += [st.text(min_size=MAX_TEXT + 1, max_size=MAX_TEXT + 2), st.integers()]
    else:
        bad += [st.integers(), st.text(min_size=1, max_size=3)]
    return st.one_of(bad)


@st.composite
def valid_record(draw: st.DrawFn, kind: str) -> dict[str, Any]:
    record: dict[str, Any] = {"robot": "uav1", "type": kind, "ts": 1.7e9}
    for key, spec in RECORDS[kind].items():
        if spec.required or draw(st.booleans()):
            record[key] = draw(st.one_of(valid_value(spec, AERIAL), st.none())
                               if not spec.required else valid_value(spec, AERIAL))
    return record


@pytest.mark.parametrize("kind", sorted(RECORDS))
def test_every_record_inside_its_declaration_passes(kind: str) -> None:
    @settings(max_examples=60, deadline=None)
    @given(valid_record(kind))
    def check(record: dict[str, Any]) -> None:
        assert check_record(record, AERIAL) == record
        assert RecordValidator(["uav1"], default=AERIAL).check("uav1", record) == record
    check()


@pytest.mark.parametrize("kind", sorted(RECORDS))
def test_any_field_outside_its_declaration_is_refused(kind: str) -> None:
    fields = sorted(RECORDS[kind])

    @settings(max_examples=80, deadline=None)
    @given(valid_record(kind), st.sampled_from(fields), st.data())
    def check(record: dict[str, Any], key: str, data: st.DataObject) -> None:
        record[key] = data.draw(invalid_value(RECORDS[kind][key], AERIAL))
        with pytest.raises(Rejected) as refused:
            check_record(record, AERIAL)
        assert refused.value.reason.startswith(f"{kind}.{key}")
    check()


@pytest.mark.parametrize("kind", sorted(k for k, f in RECORDS.items()
                                        if any(s.required for s in f.values())))
def test_a_missing_required_field_is_refused(kind: str) -> None:
    for key, spec in RECORDS[kind].items():
        if spec.required:
            record = {"type": kind, **{k: 1 for k in RECORDS[kind] if k != key}}
            with pytest.raises(Rejected, match=f"{kind}.{key} missing"):
                check_record(record, AERIAL)


@pytest.mark.parametrize("kind", sorted(RECORDS))
def test_the_quick_look_takes_only_what_the_full_check_takes(kind: str) -> None:
    """`check_record` first looks quickly at a well-formed record (`_fits`); it must never
    let through what the full check refuses, and must take the records links send."""
    fields = sorted(RECORDS[kind])
    limits = DEFAULT_LIMITS[RobotType.GROUND].overridden({"alt": [0.0, math.inf]})

    @settings(max_examples=80, deadline=None)
    @given(valid_record(kind), st.lists(st.sampled_from(fields), max_size=2), st.data())
    def check(record: dict[str, Any], spoiled: list[str], data: st.DataObject) -> None:
        assert _fits(dict(record), AERIAL)
        for key in spoiled:
            record[key] = data.draw(st.one_of(invalid_value(RECORDS[kind][key], AERIAL),
                                              st.none()))
        for lim in (AERIAL, limits):
            if _fits(record, lim):
                try:
                    _full_check(record, lim)
                except Rejected as exc:
                    pytest.fail(f"quick look took {record}, the full check refused: {exc}")
    check()


def _full_check(record: dict[str, Any], limits: Limits) -> None:
    """check_record without its quick look: a read-only mapping is never looked at quickly."""
    check_record(MappingProxyType(record), limits)


json_values = st.recursive(
    st.none() | st.booleans() | st.integers() | st.floats() | st.text(max_size=20),
    lambda inner: st.lists(inner, max_size=4) | st.dictionaries(st.text(max_size=5), inner,
                                                                max_size=4),
    max_leaves=30)


@settings(max_examples=300, deadline=None)
@given(st.dictionaries(st.text(max_size=12), json_values, max_size=8), st.text(max_size=8))
def test_arbitrary_data_is_taken_or_refused_never_an_other_error(data: dict[str, Any],
                                                                 robot: str) -> None:
    try:
        RecordValidator(["uav1"]).check(robot, data)
    except Rejected as exc:
        assert exc.reason
    else:
        assert robot == "uav1"


@settings(max_examples=200, deadline=None)
@given(st.text(min_size=1, max_size=64).filter(lambda r: r not in ("uav1", "ugv1")),
       st.sampled_from(sorted(RECORDS)))
def test_a_robot_that_is_not_configured_is_refused(robot: str, kind: str) -> None:
    with pytest.raises(Rejected, match="unknown robot"):
        RecordValidator(["uav1", "ugv1"]).check(robot, {"type": kind})


def test_the_observed_attacks_are_refused() -> None:
    validator = RecordValidator(["uav1", "ugv1"], limits={"uav1": AERIAL})
    hotspot = {"type": "hotspot", "id": 9, "lat": 0.0, "lon": 0.0, "temperature": 1e308}
    with pytest.raises(Rejected, match="unknown robot"):
        validator.check("fz9", hotspot)
    with pytest.raises(Rejected, match="hotspot.temperature out of range"):
        validator.check("uav1", hotspot)
    for record, reason in [({"type": "battery", "remaining": -128.0}, "battery.remaining"),
                           ({"type": "battery", "remaining": 127.0}, "battery.remaining"),
                           ({"type": "position", "lat": 214.7, "lon": 0}, "position.lat"),
                           ({"type": "position", "lat": 1, "lon": 2, "alt": 2.1e6},
                            "position.alt"),
                           ({"type": "tank", "level": 10 ** 400}, "tank.level")]:
        with pytest.raises(Rejected, match=f"{reason} out of range"):
            validator.check("uav1", record)
    with pytest.raises(Rejected, match="robot mismatch"):
        validator.check("uav1", {"type": "battery", "robot": "ugv1", "remaining": 50})


@settings(max_examples=100, deadline=None)
@given(st.integers())
def test_integers_are_bounded_without_overflow(n: int) -> None:
    if -MAX_INT <= n <= MAX_INT:
        assert plain(n) == n
    else:
        with pytest.raises(Rejected, match="out of range"):
            plain(n)


def test_plain_data_is_bounded_in_size_and_depth() -> None:
    nested: Any = 1
    for _ in range(MAX_DEPTH + 1):
        nested = [nested]
    with pytest.raises(Rejected, match="nested too deeply"):
        plain(nested)
    with pytest.raises(Rejected, match="too many items"):
        plain(list(range(MAX_ITEMS + 1)))
    with pytest.raises(Rejected, match="too long"):
        plain("x" * (MAX_TEXT + 1))
    with pytest.raises(Rejected, match="not plain data"):
        plain({"a": object()})


def test_limits_are_overridden_and_robots_come_from_the_rcl_table() -> None:
    wider = AERIAL.overridden({"alt": [-10, 40_000], "speed": None})
    assert wider.alt == Range(-10.0, 40_000.0) and wider.speed == AERIAL.speed
    record = {"type": "position", "lat": 1, "lon": 2, "alt": 30_000}
    assert check_record(record, wider) == record
    sections = {"components": {"rcl": {"robots": {"uav1": {"link": "mavlink"},
                                                  "ugv1": {"link": "mqtt"}, "x": {}}},
                               "bus": {"module": "m"}}}
    assert configured_robots(sections) == {"uav1": RobotType.AERIAL,
                                           "ugv1": RobotType.GROUND, "x": RobotType.GROUND}


finite = st.floats(allow_nan=False, allow_infinity=False) | st.integers(-10**6, 10**6)


@settings(max_examples=80, deadline=None)
@given(st.sampled_from(LIMIT_NAMES), st.one_of(
    st.lists(finite, min_size=2, max_size=2),
    st.lists(st.one_of(finite, st.just(math.nan), st.just(math.inf), st.booleans(),
                       st.text(max_size=3), st.none()), max_size=3),
    st.text(max_size=5), finite))
def test_limit_overrides_take_finite_ordered_pairs_and_refuse_the_rest(name: str,
                                                                        value: Any) -> None:
    good = (isinstance(value, list) and len(value) == 2
            and all(isinstance(v, int | float) and not isinstance(v, bool)
                    and math.isfinite(v) for v in value) and value[0] <= value[1])
    try:
        overrides = limit_overrides({f"{name}_range": value})
    except Rejected as exc:
        assert not good and exc.reason == f"{name}_range"
        return
    assert good and overrides == {name: [float(value[0]), float(value[1])]}
    limits = AERIAL.overridden(overrides)
    assert getattr(limits, name) == Range(float(value[0]), float(value[1]))
    assert float(value[0]) in getattr(limits, name) and float(value[1]) in getattr(limits, name)
    assert math.nextafter(float(value[1]), math.inf) not in getattr(limits, name)


def test_refusals_are_logged_once_per_source_and_reason_then_summarised(
        caplog: pytest.LogCaptureFixture) -> None:
    now = [0.0]
    rejections = RejectionLog(logging.getLogger("test.rejections"), "record", interval=60,
                              clock=lambda: now[0])
    with caplog.at_level(logging.WARNING, logger="test.rejections"):
        for _ in range(50):
            rejections.reject("fz9", "unknown robot", "'fz9' is not a configured robot")
        rejections.reject("uav1", "position.lat out of range", "214.7")
        assert len(caplog.records) == 2  # one line per (source, reason), 51 refusals
        now[0] = 61.0
        rejections.reject("fz9", "unknown robot")
        lines = [r.getMessage() for r in caplog.records]
    assert len(lines) == 4, lines
    assert "refused 49 more record(s) (total 52): fz9: unknown robot x49" in lines[2]
    assert "Traceback" not in caplog.text
    assert rejections.total == 52
    assert rejections.stats() == {"fz9: unknown robot": 51,
                                  "uav1: position.lat out of range": 1}
    # a source that goes quiet: its held-back refusals are summarised when the interval
    # ends (the component's reporter rolls every log), once
    with caplog.at_level(logging.WARNING, logger="test.rejections"):
        rejections.reject("fz9", "unknown robot")
        rejections.reject("fz9", "unknown robot")
        rejections.roll()
        assert len(caplog.records) == 4  # the interval is not over
        now[0] = 130.0
        rejections.roll()
        rejections.roll()
    lines = [r.getMessage() for r in caplog.records]
    assert len(lines) == 5 and "refused 2 more record(s) (total 54): fz9: unknown robot x2" \
        in lines[4], lines


def test_refusals_of_ever_new_kinds_stay_a_few_lines_and_a_bounded_count(
        caplog: pytest.LogCaptureFixture) -> None:
    """A reason or source that differs in every message (a name in it, a new client)
    must not make a line per message, nor a counter per message."""
    now = [0.0]
    rejections = RejectionLog(logging.getLogger("test.rejections"), "record", interval=60,
                              clock=lambda: now[0])
    with caplog.at_level(logging.WARNING, logger="test.rejections"):
        for n in range(MAX_COUNTED_KINDS + 500):
            rejections.reject(f"ghost{n}", "unknown robot")
        assert len(caplog.records) == MAX_LOGGED_KINDS
        now[0] = 61.0
        rejections.roll()
    lines = [r.getMessage() for r in caplog.records]
    assert len(lines) == MAX_LOGGED_KINDS + 1, lines
    assert f"refused {MAX_COUNTED_KINDS + 500 - MAX_LOGGED_KINDS} more record(s)" in lines[-1]
    assert "*: other kinds x500" in lines[-1] and "and 981 more kinds" in lines[-1]
    assert rejections.total == MAX_COUNTED_KINDS + 500
    assert len(rejections.stats()) == MAX_COUNTED_KINDS + 1
    assert rejections.stats()["*: other kinds"] == 500
