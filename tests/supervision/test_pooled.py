"""Pooled actors (mrss.supervision.pooled): a thread only while there is mail, pykka's
semantics otherwise (order, one message at a time, start hook first, stop)."""

from __future__ import annotations

import threading
from collections.abc import Iterator
from typing import Any

import pykka
import pytest
from pykka._envelope import Envelope

from mrss.supervision import ActorContext, SupervisedActor
from mrss.supervision.pooled import TURN_MESSAGES
from mrss.testing import wait_until


class Recorder(SupervisedActor):
    pooled = True

    def __init__(self, ctx: ActorContext, gate: threading.Event | None = None) -> None:
        super().__init__(ctx)
        self.gate = gate
        self.seen: list[Any] = []
        self.inside = 0
        self.overlaps = 0

    def setup(self) -> None:
        if self.gate is not None:
            assert self.gate.wait(10)
        self.seen.append("setup")

    def on_receive(self, message: Any) -> Any:
        self.inside += 1
        if self.inside > 1:
            self.overlaps += 1
        try:
            if isinstance(message, threading.Event):
                assert message.wait(10)  # a handler that blocks
            if message == "seen":
                return list(self.seen)
            if message == "overlaps":
                return self.overlaps
            self.seen.append(message)
            return message
        finally:
            self.inside -= 1


@pytest.fixture()
def started() -> Iterator[list[pykka.ActorRef[Any]]]:
    refs: list[pykka.ActorRef[Any]] = []
    yield refs
    for ref in refs:
        ref.stop(block=False)


def test_many_pooled_actors_hold_no_thread_each(started: list[pykka.ActorRef[Any]]) -> None:
    before = threading.active_count()
    for k in range(200):
        started.append(Recorder.start(ActorContext.standalone(f"r{k}")))
    for k, ref in enumerate(started):
        assert ref.ask(k, timeout=10) == k
    assert threading.active_count() - before < 20  # a thread each would be 200


def test_messages_are_handled_in_order_one_at_a_time(
        started: list[pykka.ActorRef[Any]]) -> None:
    ref = Recorder.start(ActorContext.standalone("r"))
    started.append(ref)
    count = 5 * TURN_MESSAGES

    def send(name: str) -> None:
        for n in range(count):
            ref.tell((name, n))

    senders = [threading.Thread(target=send, args=(f"s{k}",)) for k in range(4)]
    for each in senders:
        each.start()
    for each in senders:
        each.join()
    wait_until(lambda: len(ref.ask("seen", timeout=10)) == 1 + 4 * count, timeout=20,
               message="every message handled")
    seen = ref.ask("seen", timeout=10)
    assert seen[0] == "setup"
    for k in range(4):
        assert [n for name, n in seen[1:] if name == f"s{k}"] == list(range(count))
    assert ref.ask("overlaps", timeout=10) == 0


def test_mail_waits_for_the_start_hook(started: list[pykka.ActorRef[Any]]) -> None:
    gate = threading.Event()
    ref = Recorder.start(ActorContext.standalone("r"), gate)
    started.append(ref)
    answer = ref.ask("first", block=False)
    ref.tell("second")
    gate.set()
    assert answer.get(timeout=10) == "first"
    assert ref.ask("seen", timeout=10) == ["setup", "first", "second"]


def test_a_blocked_handler_holds_up_only_its_own_actor(
        started: list[pykka.ActorRef[Any]]) -> None:
    blocked, other = (Recorder.start(ActorContext.standalone(n)) for n in ("a", "b"))
    started += [blocked, other]
    release = threading.Event()
    blocked.tell(release)
    later = blocked.ask("after", block=False)
    try:
        assert other.ask("meanwhile", timeout=10) == "meanwhile"
    finally:
        release.set()
    assert later.get(timeout=10) == "after"


def test_a_stopped_pooled_actor_answers_no_more() -> None:
    ref = Recorder.start(ActorContext.standalone("r"))
    assert ref.ask("one", timeout=10) == "one"
    ref.stop(timeout=10)
    with pytest.raises(pykka.ActorDeadError):
        ref.ask("two", timeout=10)
    assert ref.actor_stopped.is_set()
    late = pykka.ThreadingFuture[Any]()
    ref.actor_inbox.put(Envelope("late", reply_to=late))  # past pykka's own check
    with pytest.raises(pykka.ActorDeadError):
        late.get(timeout=10)  # mail after the stop is answered, not lost
