"""EventOutbox: the root's events held across a bus proxy restart (rules in outbox.py)."""

from __future__ import annotations

import threading

import pytest

from mrss.messages import LogRecord, Message, SupEvent
from mrss.supervision.outbox import EventOutbox, covers_sup_events
from mrss.testing import wait_until


class Bus:
    """What the outbox publishes, and the subscriptions the proxy passes on."""

    def __init__(self) -> None:
        self.lock = threading.Lock()
        self.sent: list[Message] = []
        self.pending: list[str] = []

    def publish(self, msg: Message) -> None:
        with self.lock:
            self.sent.append(msg)

    def subscribe(self, prefix: str) -> None:
        with self.lock:
            self.pending.append(prefix)

    def watch(self) -> list[str]:
        with self.lock:
            found, self.pending = self.pending, []
        return found

    def children(self) -> list[tuple[str, str]]:
        with self.lock:
            return [(m.event, m.child) for m in self.sent if isinstance(m, SupEvent)]


def sup(event: str, child: str = "bus") -> SupEvent:
    return SupEvent(event=event, child=child, supervisor="demo")


@pytest.fixture()
def bus() -> Bus:
    return Bus()


def outbox(bus: Bus, **kwargs: float) -> EventOutbox:
    return EventOutbox(bus.publish, "bus", bus.watch, settle=kwargs.pop("settle", 0.0),
                       **kwargs)  # type: ignore[arg-type]


def test_events_pass_while_the_proxy_is_up(bus: Bus) -> None:
    box = outbox(bus)
    box(sup("start"))  # the proxy's first start: nothing was held
    box(sup("exit", "rcl"))
    assert bus.children() == [("start", "bus"), ("exit", "rcl")] and not box.holding


def test_events_from_the_proxys_exit_wait_for_a_sup_subscriber_of_the_new_one(
        bus: Bus) -> None:
    box = outbox(bus)
    bus.subscribe("sup.")  # seen through the old proxy: says nothing about the new one
    box(sup("exit"))
    box(sup("restart"))
    box(sup("exit", "rcl"))
    box(sup("start"))
    bus.subscribe("")  # the new proxy itself
    bus.subscribe("sup.tree")  # hears only tree answers
    box(sup("start", "rcl"))
    assert bus.children() == [] and box.holding
    bus.subscribe("sup.")
    wait_until(lambda: len(bus.children()) == 5, 5, message="the held events")
    assert bus.children() == [("exit", "bus"), ("restart", "bus"), ("exit", "rcl"),
                              ("start", "bus"), ("start", "rcl")]
    box(sup("restart", "rcl"))  # and then straight through again
    assert bus.children()[-1] == ("restart", "rcl") and not box.holding


def test_held_events_go_out_after_max_wait_without_a_subscriber(bus: Bus) -> None:
    box = outbox(bus, max_wait=0.2)
    box(sup("exit"))
    box(sup("start"))
    wait_until(lambda: len(bus.children()) == 2, 5, message="the held events")


def test_a_proxy_that_dies_again_keeps_the_events_held_in_order(bus: Bus) -> None:
    box = outbox(bus)
    box(sup("exit"))
    box(sup("start"))
    box(sup("exit"))  # before anyone subscribed: the first wait is void
    bus.subscribe("s")  # through the next proxy, whichever waiter reads it
    assert bus.children() == [] and box.holding
    box(sup("start"))
    wait_until(lambda: len(bus.children()) == 4, 5, message="the held events")
    assert [e for e, _ in bus.children()] == ["exit", "start", "exit", "start"]


def test_at_most_limit_events_are_held_the_oldest_dropped(bus: Bus) -> None:
    box = outbox(bus, limit=3)
    box(sup("exit"))
    for n in range(4):
        box(LogRecord(component="x", level="INFO", message=str(n)))
    box.close()
    assert [m.message for m in bus.sent if isinstance(m, LogRecord)] == ["1", "2", "3"]


@pytest.mark.parametrize(("prefix", "covers"), [
    ("sup.", True), ("sup", True), ("s", True), ("", False), ("sup.tree", False),
    ("log.", False)])
def test_only_a_subscriber_of_every_sup_event_counts(prefix: str, covers: bool) -> None:
    assert covers_sup_events(prefix) is covers
