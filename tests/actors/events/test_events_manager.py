"""The External Events Manager runs the project adapter over real MQTT brokers.

Percepts leave through the manager's publisher; here it records what would go on the bus
(the bus itself is tested in tests/bus and end to end in test_edge_bus.py).
"""

from __future__ import annotations

import json
import threading
from collections.abc import Iterator
from contextlib import contextmanager
from typing import Any

import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from mrss.actors.events.service import ExternalEventsManager
from mrss.edge.mqtt_client import MqttClient, MqttSettings
from mrss.messages import Message, Percept
from mrss.testing import BrokerInfo, wait_until
from tests.edge.fixture_project import PROJECT_FIXTURE
from tests.edge.termcheck import read_literal


class Recorder:
    """Records published messages (thread-safe)."""

    def __init__(self) -> None:
        self.messages: list[Message] = []
        self.lock = threading.Lock()

    def publish(self, msg: Message, topic: str | None = None) -> str:
        with self.lock:
            self.messages.append(msg)
        return str(len(self.messages))

    def literals(self) -> list[str]:
        with self.lock:
            return [m.literal for m in self.messages if isinstance(m, Percept)]


@contextmanager
def running_manager(url: str) -> Iterator[tuple[ExternalEventsManager, Recorder, MqttClient]]:
    recorder = Recorder()
    manager = ExternalEventsManager()
    sender = MqttClient(MqttSettings.from_url(url), client_id="test-sender")
    try:
        manager.run(PROJECT_FIXTURE, {"broker": {"url": url},
                                      "events": {"topic_prefix": "fixture"}}, recorder)
        assert manager.mqtt is not None and manager.mqtt.wait_subscribed(20)
        sender.start()
        assert sender.wait_connected(20)
        yield manager, recorder, sender
    finally:
        sender.stop()
        manager.stop()


@pytest.fixture(params=["mqtt_broker", "amqtt"])
def broker(request: pytest.FixtureRequest) -> BrokerInfo:
    info: BrokerInfo = request.getfixturevalue(request.param)
    return info


def send(sender: MqttClient, topic: str, payload: Any) -> None:
    data = payload if isinstance(payload, bytes) else json.dumps(payload).encode()
    assert sender.publish(topic, data, qos=1)


def test_json_payloads_become_percepts(broker: BrokerInfo) -> None:
    with running_manager(broker.url) as (manager, recorder, sender):
        send(sender, "fixture/area", {"area": "a1", "priority": 3})
        send(sender, "fixture/cancel", {"goal": "a1"})
        wait_until(lambda: len(recorder.literals()) == 2, timeout=10, message="two percepts")
        assert recorder.literals() == ["area_goal_received(a1,3)", "goal_cancelled(a1)"]
        assert manager.stats()["percepts"] == 2 and manager.stats()["bad_payloads"] == 0


def test_injection_in_a_field_stays_one_string_argument(mqtt_broker: BrokerInfo) -> None:
    with running_manager(mqtt_broker.url) as (_, recorder, sender):
        send(sender, "fixture/area", {"area": '"), evil(', "priority": 1})
        wait_until(recorder.literals, timeout=10, message="percept")
        assert read_literal(recorder.literals()[0]) == ("area_goal_received",
                                                        ['"), evil(', 1], [])


def test_bad_payloads_are_counted_by_topic_and_never_become_percepts(
        mqtt_broker: BrokerInfo) -> None:
    with running_manager(mqtt_broker.url) as (manager, recorder, sender):
        send(sender, "fixture/area", b"\xff\xfe\x00")              # not UTF-8
        send(sender, "fixture/area", b"{nope")                     # not JSON
        send(sender, "fixture/area", {"area": "a1"})               # missing field
        send(sender, "fixture/cancel", {"goal": "Not An Atom"})    # bad atom
        send(sender, "fixture/priority", {"goal": "g1", "level": "high"})  # fails half-way
        send(sender, "fixture/crash", b"anything")                 # adapter bug
        send(sender, "fixture/area", {"area": "a9", "priority": 2})  # still serving
        wait_until(lambda: recorder.literals() == ["area_goal_received(a9,2)"], timeout=10,
                   message="only the good percept")
        stats = manager.stats()
        assert stats["bad_payloads"] == 5 and stats["handler_errors"] == 1
        assert stats["bad_by_topic"] == {"fixture/area": 3, "fixture/cancel": 1,
                                         "fixture/priority": 1}
        assert "adapter bug" in str(stats["last_error"])
        assert "priority_change_seen" not in recorder.literals()


def _expected_valid(payload: bytes) -> bool:
    """Independent of the schema code: is this an {area: text, priority: int} object?"""
    try:
        obj = json.loads(payload.decode("utf-8"))
    except (UnicodeDecodeError, ValueError):
        return False
    if not isinstance(obj, dict) or not isinstance(obj.get("area"), str):
        return False
    priority = obj.get("priority")
    try:
        obj["area"].encode("utf-8")
    except UnicodeEncodeError:
        return False
    return isinstance(priority, int) and not isinstance(priority, bool)


json_junk = st.recursive(
    st.none() | st.booleans() | st.integers() | st.floats(allow_nan=False) | st.text(max_size=20),
    lambda inner: st.lists(inner, max_size=3) | st.dictionaries(st.text(max_size=5), inner,
                                                                 max_size=3),
    max_leaves=8)
near_miss = st.fixed_dictionaries(
    {"area": st.one_of(st.text(max_size=20), json_junk)},
    optional={"priority": json_junk, "extra": json_junk})
payloads = st.one_of(
    st.binary(max_size=100),
    json_junk.map(lambda v: json.dumps(v).encode()),
    near_miss.map(lambda v: json.dumps(v).encode()),
)


def test_fuzzed_payloads_never_crash_and_only_valid_ones_become_percepts(
        mqtt_broker: BrokerInfo) -> None:
    with running_manager(mqtt_broker.url) as (manager, recorder, sender):
        sentinel = 0

        @settings(max_examples=80, deadline=None,
                  suppress_health_check=[HealthCheck.too_slow])
        @given(payloads)
        def check(payload: bytes) -> None:
            nonlocal sentinel
            before_bad = manager.counters.bad_payloads
            before = len(recorder.literals())
            sentinel += 1
            send(sender, "fixture/area", payload)
            send(sender, "fixture/area", {"area": f"s{sentinel}", "priority": sentinel})
            marker = f"area_goal_received(s{sentinel},{sentinel})"
            wait_until(lambda: marker in recorder.literals(), timeout=10, message="sentinel")
            new = recorder.literals()[before:]
            if _expected_valid(payload):
                assert len(new) == 2 and new[1] == marker
                assert read_literal(new[0])[0] == "area_goal_received"
                assert manager.counters.bad_payloads == before_bad
            else:
                assert new == [marker]
                assert manager.counters.bad_payloads == before_bad + 1

        check()
        assert manager.counters.handler_errors == 0
