"""The one filter of dead incarnations (mrss/bus/incarnations.py), on a real bus: a
message of incarnation i of a sender is dropped once a later incarnation of it was heard
or announced by its supervisor; on the subscriber and on the reliable channel alike."""

from __future__ import annotations

import threading

from mrss.bus import (
    BusEndpoints,
    Incarnations,
    Publisher,
    ReliableReceiver,
    ReliableSender,
    Stale,
    Subscriber,
)
from mrss.messages import ActionRequest, ActionStatus, Envelope, Percept, SupEvent
from mrss.testing import wait_until
from tests.bus.bus_helpers import sync


def _status(uuid: str) -> ActionStatus:
    return ActionStatus(uuid=uuid, state="running")


def _sync(k: int) -> Percept:
    return Percept(literal=f"sync({k})")


def _uuids(envs: list[Envelope]) -> list[tuple[str, int]]:
    return [(e.body.uuid, e.inc) for e in envs
            if isinstance(e.body, ActionStatus) and not e.body.uuid.startswith("sync")]


def _drain(sub: Subscriber) -> list[Envelope]:
    out = []
    while (env := sub.recv(timeout=0.3)) is not None:
        out.append(env)
    return out


def test_a_dead_incarnations_late_messages_are_dropped_once_its_successor_spoke(
        proxy_thread: BusEndpoints) -> None:
    ep = proxy_thread
    with Publisher(ep, src="rcl", inc=1, batching=False) as old, \
            Publisher(ep, src="rcl", inc=2, batching=False) as new, \
            Publisher(ep, src="tool", batching=False) as tool, \
            Subscriber(ep, prefixes=["action.status", "percept"]) as sub, \
            Subscriber(ep, prefixes=["action.status"], stale=Stale.KEEP) as keeper:
        sync(tool, sub, _sync)
        sync(old, keeper, lambda k: _status(f"sync{k}"))
        old.publish(_status("a"))  # incarnation 1 while it is the live one
        got = _drain(sub)
        new.publish(_status("b"))  # incarnation 2 speaks: 1 is dead from now on
        got += _drain(sub)  # (two publishers' messages may pass each other on the way)
        old.publish(_status("late"))
        new.publish(_status("c"))
        tool.publish(Percept(literal="from_an_unsupervised_sender"))  # inc 0: never stale
        got += _drain(sub)
        assert _uuids(got) == [("a", 1), ("b", 2), ("c", 2)]
        assert any(isinstance(e.body, Percept) and e.body.literal.startswith("from_an")
                   for e in got)
        assert sub.stale == 1
        kept = _uuids(_drain(keeper))  # an observer sees all
        assert sorted(kept) == [("a", 1), ("b", 2), ("c", 2), ("late", 1)]
        assert keeper.stale == 0


def test_the_supervisors_announcement_makes_the_old_incarnation_stale_before_the_new_speaks(
        proxy_thread: BusEndpoints) -> None:
    ep = proxy_thread
    with Publisher(ep, src="rcl", inc=1, batching=False) as old, \
            Publisher(ep, src="supervisor", batching=False) as root, \
            Subscriber(ep, prefixes=["action.status"]) as sub:
        sync(old, sub, lambda k: _status(f"sync{k}"))
        root.publish(SupEvent(event="start", child="rcl", supervisor="wildfire",
                              detail={"inc": 2}))
        # the announcement is heard though not subscribed to (and not delivered); until
        # it has arrived (two publishers: no order between them), "late" may pass
        def late_dropped() -> bool:
            old.publish(_status("late"))
            while (env := sub.recv(timeout=0.1)) is not None:
                assert isinstance(env.body, ActionStatus), env  # never the announcement
            return sub.stale > 0

        wait_until(late_dropped, 10, message="the announcement taking effect")
        old.publish(_status("later"))  # after it: always dropped
        assert _uuids(_drain(sub)) == [] and sub.stale >= 2


def test_the_reliable_channel_acknowledges_a_dead_incarnations_message_and_never_handles_it(
        proxy_thread: BusEndpoints) -> None:
    ep = proxy_thread
    handled: list[tuple[str, int]] = []
    lock = threading.Lock()

    def handler(env: Envelope) -> None:
        assert isinstance(env.body, ActionRequest)
        with lock:
            handled.append((env.body.uuid, env.inc))

    live = Incarnations("rcl")
    live.learn("reasoner", 2)  # e.g. from the journal of a restarted RCL
    with ReliableReceiver(ep, src="rcl", channel="action", handler=handler,
                          incarnations=live) as rx, \
            ReliableSender(ep, src="reasoner", inc=1, channel="action") as dead, \
            ReliableSender(ep, src="reasoner", inc=2, channel="action") as alive:
        dead.send(ActionRequest(uuid="late", name="go", args=[]))
        alive.send(ActionRequest(uuid="new", name="go", args=[]))
        wait_until(lambda: dead.pending() == 0 and alive.pending() == 0, 10,
                   message="both acknowledged")
        assert handled == [("new", 2)]
        assert rx.stale == 1 and live.dropped == 1
