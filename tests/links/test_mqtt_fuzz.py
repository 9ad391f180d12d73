"""Fuzzed payloads over a real broker: to the UGV's command topic and the link's topics.

Bad input never crashes either side, never changes the robot, never becomes telemetry.
"""

from __future__ import annotations

import itertools
import json
import math
from collections.abc import Iterator
from typing import Any

import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from mrss.errors import DecodeError
from mrss.links.mqtt import MqttLink
from mrss.links.mqtt_probe import MqttProbe as Probe
from mrss.links.ugv_protocol import UgvTopics, parse_command, parse_telemetry
from mrss.sim.ugv import SimUgv
from mrss.testing import BrokerInfo, wait_until

FUZZ = settings(max_examples=40, deadline=None,
                suppress_health_check=[HealthCheck.function_scoped_fixture])

json_values = st.recursive(
    st.none() | st.booleans() | st.integers() | st.floats(allow_nan=False) | st.text(max_size=20),
    lambda inner: st.lists(inner, max_size=4) | st.dictionaries(st.text(max_size=10), inner,
                                                                max_size=4),
    max_leaves=12,
)
bad_values = st.one_of(st.none(), st.text(max_size=5), st.just(True), st.just(float("nan")),
                       st.just(1e300), st.just(-1e300), st.lists(st.integers(), max_size=2))

VALID_TELEMETRY: dict[str, Any] = {
    "id": "fz1", "ts": 1.0, "lat": -35.0, "lon": 149.0, "heading": 10.0, "speed": 1.0,
    "battery": 90.0, "tank": 10.0, "tank_capacity": 50.0, "pumping": False, "mode": "idle",
    "at_base": False, "teleop": False,
}


@st.composite
def broken_telemetry(draw: st.DrawFn) -> bytes:
    """Valid telemetry with one field missing or given a wrong value."""
    sample = dict(VALID_TELEMETRY)
    key = draw(st.sampled_from(sorted(sample)))
    if draw(st.booleans()):
        del sample[key]
    else:
        sample[key] = draw(bad_values.filter(lambda v: _wrong_for(key, v)))
    return json.dumps(sample).encode()


def _wrong_for(key: str, value: Any) -> bool:
    """Whether `value` is really invalid for `key` (a text for "mode" may be a mode)."""
    sample = dict(VALID_TELEMETRY, **{key: value})
    try:
        parse_telemetry(json.dumps(sample).encode(), "fz1")
    except DecodeError:
        return True
    return False


payloads = st.one_of(st.binary(max_size=200), json_values.map(lambda v: json.dumps(v).encode()),
                     broken_telemetry())


@pytest.fixture(scope="module")
def fuzz_link(mqtt_broker: BrokerInfo) -> Iterator[tuple[MqttLink, list[dict[str, Any]], Probe]]:
    records: list[dict[str, Any]] = []
    link = MqttLink("fz1", mqtt_broker.url, telemetry_timeout=30, on_telemetry=records.append)
    topics = UgvTopics.for_robot("fz1")
    probe = Probe(mqtt_broker.host, mqtt_broker.port, [])
    link.start()
    try:
        def up_after_telemetry() -> bool:  # the link subscribes in the background
            probe.publish(topics.telemetry, json.dumps(VALID_TELEMETRY))
            return link.up

        wait_until(up_after_telemetry, timeout=10, interval=0.1, message="fuzz link up")
        yield link, records, probe
    finally:
        link.close()
        probe.close()


_CALLS = itertools.count()
_SENTINELS: set[float] = set()  # the sentinels of earlier calls


@FUZZ
@given(payload=payloads, marker=st.integers(0, 10**6))
def test_bad_telemetry_never_becomes_telemetry(
        fuzz_link: tuple[MqttLink, list[dict[str, Any]], Probe], payload: bytes,
        marker: int) -> None:
    link, records, probe = fuzz_link
    topics = UgvTopics.for_robot("fz1")
    valid = True
    try:
        parse_telemetry(payload, "fz1")
    except DecodeError:
        valid = False
    records.clear()
    bad_before = link.bad_messages
    probe.publish(topics.telemetry, payload)
    for topic in (topics.ack, topics.status):
        probe.publish(topic, payload)
    # A sentinel of its own per call (Hypothesis repeats markers), and earlier calls'
    # sentinels are left out: a late or repeated delivery of one (QoS 1) is no record of
    # this payload. The bad payload itself must have made no position.
    sentinel_lat = -35.0 - (marker + next(_CALLS) * 10**7) * 1e-9
    probe.publish(topics.telemetry, json.dumps(dict(VALID_TELEMETRY, lat=sentinel_lat)))
    wait_until(lambda: any(r["type"] == "position" and r["lat"] == sentinel_lat
                           for r in list(records)), timeout=5, message="sentinel telemetry")
    positions = [r["lat"] for r in records if r["type"] == "position"
                 and r["lat"] not in _SENTINELS]
    _SENTINELS.add(sentinel_lat)
    if not valid:
        assert set(positions) == {sentinel_lat}
        assert link.bad_messages >= bad_before + 1
    assert link.up


@pytest.mark.slow
@FUZZ
@given(payload=st.one_of(st.binary(max_size=200),
                         json_values.map(lambda v: json.dumps(v).encode()),
                         st.fixed_dictionaries({"cmd": st.sampled_from(["goto", "pump", "drive",
                                                                        "teleop", "nope"]),
                                                "lat": bad_values, "on": bad_values,
                                                "speed": bad_values})
                         .map(lambda d: json.dumps(d).encode())))
def test_bad_commands_never_crash_or_move_the_ugv(
        sim_ugv: tuple[SimUgv, Probe], payload: bytes) -> None:
    ugv, probe = sim_ugv
    topics = ugv.topics
    try:
        parse_command(payload)
        valid = True
    except DecodeError:
        valid = False
    before = ugv.snapshot()
    bad_before = ugv.bad_commands
    probe.publish(topics.cmd, payload)
    sentinel = f"s{len(probe.messages)}-{abs(hash(payload))}"
    probe.publish(topics.cmd, json.dumps({"cmd": "stop", "id": sentinel}))
    wait_until(lambda: any(json.loads(p).get("id") == sentinel
                           for p in probe.received(topics.ack)), timeout=5, message="stop ack")
    if not valid:
        assert ugv.bad_commands == bad_before + 1
        after = ugv.snapshot()
        assert (after.lat, after.lon, after.tank, after.mode) == \
            (before.lat, before.lon, before.tank, before.mode)


@pytest.fixture(scope="module")
def sim_ugv(mqtt_broker: BrokerInfo) -> Iterator[tuple[SimUgv, Probe]]:
    ugv = SimUgv(mqtt_broker.url, "fzugv", speedup=1.0)
    probe = Probe(mqtt_broker.host, mqtt_broker.port, [ugv.topics.ack, ugv.topics.status])
    ugv.start()
    try:
        wait_until(lambda: b"online" in probe.received(ugv.topics.status), timeout=10,
                   message="sim online")
        yield ugv, probe
    finally:
        ugv.stop()
        probe.close()


@given(payload=st.binary(max_size=300))
def test_parse_command_raises_only_decode_error(payload: bytes) -> None:
    try:
        command = parse_command(payload)
    except DecodeError:
        return
    for value in (command.lat, command.lon, command.speed, command.heading, command.litres):
        assert value is None or math.isfinite(value)


@pytest.mark.parametrize("key", ["lat", "lon", "battery", "tank", "tank_capacity", "speed"])
def test_a_huge_integer_is_refused_not_an_overflow(key: str) -> None:
    payload = json.dumps(dict(VALID_TELEMETRY, **{key: 10 ** 400})).encode()
    with pytest.raises(DecodeError, match="out of range"):
        parse_telemetry(payload, "fz1")


def test_a_huge_integer_over_the_broker_is_a_counted_bad_message(
        fuzz_link: tuple[MqttLink, list[dict[str, Any]], Probe],
        caplog: pytest.LogCaptureFixture) -> None:
    link, records, probe = fuzz_link
    topics = UgvTopics.for_robot("fz1")
    before = link.rejections.total
    with caplog.at_level("WARNING"):
        for _ in range(5):
            probe.publish(topics.telemetry, json.dumps(dict(VALID_TELEMETRY, lat=10 ** 400)))
        wait_until(lambda: link.rejections.total >= before + 5, timeout=5,
                   message="the five refusals counted")
    assert not [r for r in caplog.records if "error handling" in r.getMessage()]
    assert not [r for r in caplog.records if r.exc_info]  # no traceback
    assert sum("'lat' out of range" in r.getMessage() for r in caplog.records) <= 1
    assert not [r for r in records if r.get("lat") == 10 ** 400]
    assert link.up
