"""The one filter of dead incarnations (mrss/bus/incarnations.py), on a real bus: a
message of incarnation i of a sender is dropped once a later incarnation of it was heard
or announced by its supervisor; on the subscriber and on the reliable channel alike."""

from __future__ import annotations

import threading
from pathlib import Path

from mrss.bus import (
    BusEndpoints,
    Incarnations,
    Publisher,
    ReliableReceiver,
    ReliableSender,
    Stale,
    Subscriber,
)
from mrss.bus.incarnations import MAX_COUNTED, OTHER_SENDERS, Refusal, refusal_counts
from mrss.messages import (
    ActionRequest,
    ActionStatus,
    Envelope,
    IncarnationKey,
    Percept,
    SupEvent,
    decode,
    encode,
    mark_replayed,
)
from mrss.testing import wait_until
from tests.bus.bus_helpers import drain_until, receive_until, sync


def _status(uuid: str) -> ActionStatus:
    return ActionStatus(uuid=uuid, state="running")


def _sync(k: int) -> Percept:
    return Percept(literal=f"sync({k})")


def _uuids(envs: list[Envelope]) -> list[tuple[str, int]]:
    return [(e.body.uuid, e.inc) for e in envs
            if isinstance(e.body, ActionStatus) and not e.body.uuid.startswith("sync")]


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
        got = drain_until(sub, _status("a"))
        new.publish(_status("b"))  # incarnation 2 speaks: 1 is dead from now on
        got += drain_until(sub, _status("b"))  # (two publishers' messages may pass each
        old.publish(_status("late"))           # other on the way: one at a time)
        new.publish(_status("c"))
        unsupervised = Percept(literal="from_an_unsupervised_sender")  # inc 0: never stale
        tool.publish(unsupervised)
        # "late" has no successor on its publisher that `sub` could see: it is in once
        # it was dropped (or, were the filter broken, delivered).
        def all_in(more: list[Envelope]) -> bool:
            bodies = [e.body for e in more]
            return (sub.stale == 1 or ("late", 1) in _uuids(more)) \
                and _status("c") in bodies and unsupervised in bodies

        got += receive_until(sub, all_in, what="late, c and the unsupervised percept")
        assert _uuids(got) == [("a", 1), ("b", 2), ("c", 2)]
        assert sub.stale == 1
        kept = _uuids(drain_until(keeper, _status("late"), _status("c")))  # sees all
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
        dropped = sub.stale
        old.publish(_status("later"))  # after it: always dropped
        got = receive_until(sub, lambda more: sub.stale > dropped or _uuids(more) != [],
                            what="'later' dropped or delivered")
        assert _uuids(got) == [] and sub.stale == dropped + 1


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


def test_on_a_keyed_bus_only_a_proven_incarnation_raises_the_bar(
        proxy_thread: BusEndpoints, tmp_path: Path) -> None:
    (tmp_path / "run").mkdir()
    (tmp_path / "other").mkdir()
    key = IncarnationKey.create(tmp_path / "run")
    ep = proxy_thread.keyed(key.path)  # what the root hands its components
    foreign = IncarnationKey.create(tmp_path / "other")  # another run's key
    handled: list[tuple[str, int]] = []
    lock = threading.Lock()

    def handler(env: Envelope) -> None:
        assert isinstance(env.body, ActionRequest)
        with lock:
            handled.append((env.body.uuid, env.inc))

    def request(uuid: str) -> ActionRequest:
        return ActionRequest(uuid=uuid, name="go", args=[])

    live = Incarnations("rcl")
    with ReliableReceiver(ep, src="rcl", channel="action", handler=handler,
                          incarnations=live) as rx, \
            ReliableSender(ep, src="reasoner", inc=1, channel="action") as alive, \
            ReliableSender(proxy_thread, src="reasoner", inc=10**9, channel="action") as forged, \
            ReliableSender(proxy_thread.keyed(foreign.path), src="reasoner", inc=2,
                           channel="action") as replayed_elsewhere, \
            Publisher(ep, src="supervisor", batching=False) as root, \
            Subscriber(ep, prefixes=["action.control"], incarnations=live) as controls:
        alive.send(request("a"))
        wait_until(lambda: alive.pending() == 0, 10, message="a acknowledged")
        forged.send(request("forged"))  # no credential
        replayed_elsewhere.send(request("foreign"))  # another run's credential
        wait_until(lambda: forged.pending() == 0 and replayed_elsewhere.pending() == 0, 10,
                   message="both acknowledged (refused)")
        alive.send(request("b"))  # the bar did not move: the live reasoner is heard
        wait_until(lambda: alive.pending() == 0, 10, message="b acknowledged")
        assert handled == [("a", 1), ("b", 1)]
        assert live.refused[("reasoner", Refusal.UNPROVEN)] == 2 and rx.stale == 2
        assert refusal_counts()[
            "bus message from reasoner: an incarnation its supervisor did not start"] >= 2
        # the root announces reasoner 2 with its credential: incarnation 1 is dead (the
        # component's subscriber hears it for the filter it shares with the receiver)
        announced = SupEvent(event="start", child="reasoner", supervisor="root",
                             detail={"inc": 2, "cred": key.credential("reasoner", 2).hex()})
        controls.start(lambda env: None)
        wait_until(lambda: root.publish(announced) and live.live("reasoner") == 2, 10,
                   interval=0.1, message="the announcement heard")
        alive.send(request("late"))
        wait_until(lambda: alive.pending() == 0, 10, message="late acknowledged")
        assert handled == [("a", 1), ("b", 1)]
        assert live.refused[("reasoner", Refusal.STALE)] == 1


def test_a_replayed_message_reaches_observers_marked_and_no_component(
        proxy_thread: BusEndpoints) -> None:
    ep = proxy_thread
    with Publisher(ep, src="tool", batching=False) as tool, \
            Subscriber(ep, prefixes=["percept"]) as component, \
            Subscriber(ep, prefixes=["percept"], stale=Stale.KEEP) as observer:
        sync(tool, component, _sync)
        sync(tool, observer, _sync)
        topic, payload = encode(Percept(literal="hotspot(h1)"), src="events", inc=1)
        tool.send_frames([topic, mark_replayed(payload)])
        tool.publish(Percept(literal="live"))
        end = Percept(literal="sync-end")  # the tool's last message: all before it is in
        tool.publish(end)
        seen = [(e.body.literal, e.replayed) for e in drain_until(observer, end)
                if isinstance(e.body, Percept) and not e.body.literal.startswith("sync")]
        assert seen == [("hotspot(h1)", True), ("live", False)]
        assert [e.body.literal for e in drain_until(component, end)
                if isinstance(e.body, Percept)
                and not e.body.literal.startswith("sync")] == ["live"]
        assert component.stale == 1


def test_refusals_of_made_up_senders_are_counted_in_bounded_memory() -> None:
    live = Incarnations("rcl", IncarnationKey(b"k" * 32))
    flood = MAX_COUNTED + 100
    for n in range(flood):
        assert not live.admit(decode(*encode(Percept(literal="x"), src=f"s{n}", inc=5)))
    assert live.dropped == flood and len(live.refused) == MAX_COUNTED + 1
    assert live.refused[(OTHER_SENDERS, Refusal.UNPROVEN)] == 100
