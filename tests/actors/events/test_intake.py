"""The event intake's rules: order, retry within a budget, outcomes reported, duplicates.

The handlers here raise the real exception types the adapters meet; percepts, bus
reports and MQTT replies are recorded where they would leave the process (the whole
path through MQTT and the bus is tested in test_edge_faults.py).
"""

from __future__ import annotations

import json
import threading
from typing import Any

import pytest

from mrss.actors.events.intake import EventIntake, InboundEvent, identify
from mrss.actors.events.reports import EventReporter, reply_template
from mrss.agentspeak.literals import Atom
from mrss.edge.retry import Attempt, RetryPolicy, classify
from mrss.errors import ConfigError
from mrss.messages import EventReport, EventStatus, Message, Percept
from mrss.runtime.percepts import PerceptPublisher
from mrss.world.access import WorldModelRejected, WorldModelUnavailable

FAST = RetryPolicy(initial=0.01, max_delay=0.05, budget=60.0)


class Outbox:
    """What left the intake: percepts (with ids), bus messages, MQTT replies, acks."""

    def __init__(self) -> None:
        self.lock = threading.Lock()
        self.percepts: list[tuple[str, str | None]] = []
        self.bus: list[Message] = []
        self.replies: list[tuple[str, dict[str, Any]]] = []
        self.acks: list[str] = []

    def percept(self, percept: Percept, msg_id: str | None) -> None:
        with self.lock:
            self.percepts.append((percept.literal, msg_id))

    def publish(self, msg: Message, topic: str | None = None) -> str:
        with self.lock:
            self.bus.append(msg)
        return "id"

    def reply(self, topic: str, payload: bytes | str, qos: int = 1,
              retain: bool = False) -> bool:
        with self.lock:
            self.replies.append((topic, json.loads(payload)))
        return True

    def reports(self, status: EventStatus) -> list[EventReport]:
        with self.lock:
            return [m for m in self.bus if isinstance(m, EventReport) and m.status == status]


class Replies:
    def __init__(self, outbox: Outbox) -> None:
        self.publish = outbox.reply


def make_intake(outbox: Outbox, policy: RetryPolicy = FAST,
                reply_accepted: bool = False) -> EventIntake:
    publisher = PerceptPublisher(outbox.percept)
    reporter = EventReporter("events", bus=outbox, replies=Replies(outbox),
                             reply_accepted=reply_accepted)
    intake = EventIntake(publisher, policy=policy, reporter=reporter)
    intake.start()
    return intake


def event(outbox: Outbox, topic: str, payload: dict[str, Any] | bytes,
          redelivered: bool = False) -> InboundEvent:
    data = payload if isinstance(payload, bytes) else json.dumps(payload).encode()
    return InboundEvent(topic, data, redelivered,
                        acknowledge=lambda: outbox.acks.append(topic))


def test_retry_policy_backs_off_within_its_budget() -> None:
    policy = RetryPolicy(initial=0.2, factor=2, max_delay=1.0, budget=2.0)
    assert [policy.delay(n) for n in range(1, 6)] == [0.2, 0.4, 0.8, 1.0, 1.0]
    assert policy.next_wait(1, elapsed=0.0) == 0.2
    assert policy.next_wait(4, elapsed=1.5) is None  # 1.5 + 1.0 > 2.0
    assert RetryPolicy.from_config({"retry_budget": 5, "retry_initial": 0.5}) == RetryPolicy(
        initial=0.5, budget=5.0)


@pytest.mark.parametrize("section", [{"retry_budget": -1}, {"retry_initial": 0},
                                     {"retry_max_delay": "5"},
                                     {"retry_initial": 3, "retry_max_delay": 1}])
def test_bad_retry_settings_name_their_key(section: dict[str, Any]) -> None:
    with pytest.raises(ConfigError, match="events.retry_"):
        RetryPolicy.from_config(section)


def test_failures_are_classified_once() -> None:
    assert classify(WorldModelUnavailable("down")) is Attempt.UNAVAILABLE
    assert classify(TimeoutError()) is Attempt.UNAVAILABLE
    assert classify(ConnectionRefusedError()) is Attempt.UNAVAILABLE
    assert classify(WorldModelRejected("HTTP 400")) is Attempt.BAD_INPUT
    assert classify(KeyError("goal")) is Attempt.BAD_INPUT
    assert classify(RuntimeError("bug")) is Attempt.HANDLER_ERROR


def test_identity_is_the_senders_id_else_the_content() -> None:
    a = identify(InboundEvent("ui/area", b'{"id": "x1", "goal": "a1"}'))
    b = identify(InboundEvent("ui/area", b'{"id": "x1", "goal": "a2"}'))
    c = identify(InboundEvent("ui/cancel", b'{"id": "x1"}'))
    assert a.key == b.key != c.key  # (topic, id)
    assert a.event_id == "x1" and a.detail == {"goal": "a1"} and a.percept_ids
    plain = identify(InboundEvent("ui/area", b'{"goal": "a1"}'))
    assert plain.event_id == "" and plain.percept_ids is None
    assert identify(InboundEvent("ui/area", b'{"id": 5}')).event_id == ""  # not a string


def test_an_event_waiting_for_a_dependency_is_retried_then_accepted() -> None:
    outbox = Outbox()
    intake = make_intake(outbox)
    failures = iter([WorldModelUnavailable("refused"), TimeoutError("slow")])

    def handler() -> None:
        failure = next(failures, None)
        if failure is not None:
            raise failure
        intake.percept("area_goal_received", Atom("a1"), 2)
    try:
        intake.submit(event(outbox, "ui/area", {"goal": "a1", "id": "op-1"}), handler)
        assert intake.wait_idle(30)
    finally:
        intake.stop()
    [(literal, msg_id)] = outbox.percepts
    assert literal == "area_goal_received(a1,2)"
    assert msg_id == f"{identify(event(outbox, 'ui/area', {'id': 'op-1'})).percept_ids}.0"
    [report] = outbox.reports(EventStatus.ACCEPTED)
    assert report.attempts == 3 and report.event_id == "op-1"
    assert intake.counters.retries == 2 and outbox.acks == ["ui/area"]
    assert outbox.replies == []  # accepted: no reply unless asked for


def test_an_event_whose_dependency_stays_down_is_reported_to_the_sender_and_the_bus() -> None:
    outbox = Outbox()
    intake = make_intake(outbox, RetryPolicy(initial=0.01, max_delay=0.02, budget=0.1))
    calls = 0

    def down() -> None:
        nonlocal calls
        calls += 1
        intake.percept("never")
        raise WorldModelUnavailable("connection refused")
    try:
        intake.submit(event(outbox, "ui/area", {"goal": "a1", "id": "op-9"}), down)
        assert intake.wait_idle(30)
        [(topic, answer)] = outbox.replies
        assert topic == "ui/area/reply"
        assert answer["status"] == "failed" and answer["id"] == "op-9"
        assert answer["goal"] == "a1" and answer["attempts"] == calls >= 2
        assert "connection refused" in answer["reason"]
        assert outbox.reports(EventStatus.FAILED)[0].event_id == "op-9"
        assert outbox.percepts == [] and outbox.acks == ["ui/area"]
        # A failed event may be sent again: it is not taken for a duplicate.
        intake.submit(event(outbox, "ui/area", {"goal": "a1", "id": "op-9"}),
                      lambda: intake.percept("area_goal_received", Atom("a1"), 1))
        assert intake.wait_idle(30)
        assert [p for p, _ in outbox.percepts] == ["area_goal_received(a1,1)"]
    finally:
        intake.stop()


def test_a_bad_payload_is_rejected_at_once_and_a_bug_is_reported_without_retry() -> None:
    outbox = Outbox()
    intake = make_intake(outbox)
    calls: list[str] = []

    def bad() -> None:
        calls.append("bad")
        raise WorldModelRejected("HTTP 400: bad object")

    def bug() -> None:
        calls.append("bug")
        raise RuntimeError("adapter bug")
    try:
        intake.submit(event(outbox, "ui/area", {"id": "b1"}), bad)
        intake.submit(event(outbox, "ui/teleop", {"id": "b2"}), bug)
        assert intake.wait_idle(30)
    finally:
        intake.stop()
    assert calls == ["bad", "bug"]
    statuses = {a["id"]: (a["status"], a["attempts"]) for _, a in outbox.replies}
    assert statuses == {"b1": ("rejected", 1), "b2": ("failed", 1)}
    assert intake.counters.bad_by_topic == {"ui/area": 1}
    assert intake.counters.handler_errors == 1


def test_repeats_are_one_event_and_events_keep_their_order() -> None:
    outbox = Outbox()
    intake = make_intake(outbox)

    def goal(name: str) -> Any:
        return lambda: intake.percept("goal", Atom(name))
    try:
        intake.submit(event(outbox, "ui/area", {"id": "g1"}), goal("g1"))
        intake.submit(event(outbox, "ui/area", {"id": "g1"}), goal("g1"))  # resent by the UI
        intake.submit(event(outbox, "ui/area", {"goal": "same"}), goal("s1"))
        intake.submit(event(outbox, "ui/area", {"goal": "same"}), goal("s2"))  # legit again
        intake.submit(event(outbox, "ui/area", {"goal": "same"}, redelivered=True),
                      goal("s3"))  # the broker's redelivery
        intake.submit(event(outbox, "ui/area/reply", {"status": "failed"}),
                      goal("reply"))  # our own answer, through a wildcard
        assert intake.wait_idle(30)
    finally:
        intake.stop()
    assert [p for p, _ in outbox.percepts] == ["goal(g1)", "goal(s1)", "goal(s2)"]
    assert len(outbox.reports(EventStatus.DUPLICATE)) == 2
    assert intake.counters.duplicates == 2
    assert len(outbox.acks) == 6  # every delivery is acknowledged, duplicates too


def test_with_reply_accepted_a_sender_that_sends_again_is_answered_each_time() -> None:
    """An operator's console sends again, with the same id, until it is answered."""
    outbox = Outbox()
    intake = make_intake(outbox, reply_accepted=True)
    try:
        for _ in range(2):
            intake.submit(event(outbox, "ui/area", {"id": "op-1", "goal": "a1"}),
                          lambda: intake.percept("goal", Atom("a1")))
        assert intake.wait_idle(30)
    finally:
        intake.stop()
    assert [p for p, _ in outbox.percepts] == ["goal(a1)"]
    assert sorted((t, a["status"], a["id"]) for t, a in outbox.replies) == [
        ("ui/area/reply", "accepted", "op-1"), ("ui/area/reply", "duplicate", "op-1")]


def test_an_event_in_hand_when_the_intake_stops_is_not_acknowledged() -> None:
    outbox = Outbox()
    intake = make_intake(outbox, RetryPolicy(initial=0.05, max_delay=0.05, budget=600))
    tried = threading.Event()

    def down() -> None:
        tried.set()
        raise WorldModelUnavailable("hung")
    intake.submit(event(outbox, "ui/area", {"id": "g1"}), down)
    assert tried.wait(30)
    intake.stop()
    assert outbox.acks == [] and outbox.replies == []  # the broker will deliver it again


@pytest.mark.parametrize("template", ["{topic}/+", "a/#", "{topic}/{topic}", "{goal}/x", 5])
def test_bad_reply_topics_name_their_key(template: object) -> None:
    with pytest.raises(ConfigError, match="events.reply_topic"):
        reply_template({"reply_topic": template})


def test_a_fixed_reply_topic_is_never_an_event() -> None:
    reporter = EventReporter("events", reply_topic="ops/errors")
    assert reporter.reply_topic_for("ui/area") == "ops/errors"
    assert reporter.is_reply_topic("ops/errors") and not reporter.is_reply_topic("ui/area")
    assert not EventReporter("events", reply_topic="").reply_topic_for("ui/area")
