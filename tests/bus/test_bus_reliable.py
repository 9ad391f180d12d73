"""The reliable channel in one process with a real proxy: repeats, order, bounds, bad input."""

from __future__ import annotations

import os
import threading
from collections.abc import Iterator

import pytest
import zmq

from mrss.bus import (
    BusEndpoints,
    NotHandled,
    Publisher,
    ReliableReceiver,
    ReliableSender,
    Subscriber,
    wire,
)
from mrss.bus.direct import forget_member, subscriber_socket
from mrss.errors import BusError, ConfigError
from mrss.messages import ActionControl, ActionRequest, Envelope, encode
from mrss.testing import wait_until
from tests.bus.bus_helpers import receive_until


class Handled:
    """A handler that records the action uuids it was called with."""

    def __init__(self, fail_on: str = "") -> None:
        self.uuids: list[str] = []
        self.fail_on = fail_on
        self._lock = threading.Lock()

    def __call__(self, env: Envelope) -> None:
        assert isinstance(env.body, ActionRequest)
        with self._lock:
            self.uuids.append(env.body.uuid)
        if env.body.uuid == self.fail_on:
            raise RuntimeError("handler bug")


def _request(uuid: str) -> ActionRequest:
    return ActionRequest(uuid=uuid, name="go", args=[])


@pytest.fixture()
def ep(proxy_thread: BusEndpoints) -> BusEndpoints:
    return proxy_thread


@pytest.fixture()
def raw(ep: BusEndpoints) -> Iterator[Publisher]:
    """A publisher for hand-made reliable frames, joined to the proxy."""
    with Publisher(ep, src="raw") as pub:
        assert pub.wait_connected(5)
        yield pub


def _frames(session: bytes, seq: int, base: int, uuid: str, msg_id: str) -> list[bytes]:
    topic, payload = encode(_request(uuid), src="raw", msg_id=msg_id)
    return [wire.data_topic("action"), topic, payload, wire.pack_header(session, seq, base)]


def test_messages_arrive_in_order_and_flush_reports_all_acknowledged(ep: BusEndpoints) -> None:
    handled = Handled()
    with ReliableReceiver(ep, src="rx", handler=handled), \
            ReliableSender(ep, src="tx", window=8) as tx:
        ids = [tx.send(_request(f"u{n}")) for n in range(300)]
        assert tx.flush(timeout=20)
        assert tx.pending() == 0
    assert handled.uuids == [f"u{n}" for n in range(300)]
    assert len(set(ids)) == 300


def test_a_receiver_that_starts_late_still_gets_everything(ep: BusEndpoints) -> None:
    handled = Handled()
    with ReliableSender(ep, src="tx", resend_after=0.05, max_resend_after=0.1) as tx:
        for n in range(50):
            tx.send(_request(f"u{n}"))
        assert not tx.flush(timeout=0.3)
        assert tx.pending() == 50
        with ReliableReceiver(ep, src="rx", handler=handled):
            assert tx.flush(timeout=10)
    assert handled.uuids == [f"u{n}" for n in range(50)]
    assert tx.resent > 0


def test_repeats_are_handled_once_and_gaps_are_filled_in_order(
    ep: BusEndpoints, raw: Publisher,
) -> None:
    handled = Handled()
    # A raw SUB (a member on a direct bus), to see the acks as they are on the wire; it is
    # read while the test waits (a direct bus's publishers join a member whose thread
    # touches its socket).
    acks, member = subscriber_socket(zmq.Context.instance(), ep, [b"rel.action.ack."])
    seen: list[list[bytes]] = []

    def take_acks() -> None:
        while acks.poll(0):
            frames = acks.recv_multipart()
            if not wire.is_answer(frames):
                seen.append(frames)

    session = os.urandom(16)
    try:
        with ReliableReceiver(ep, src="rx", handler=handled) as rx:
            # Until the receiver has joined, seq 1 is repeated as a sender would.
            wait_until(lambda: raw.send_frames(_frames(session, 1, 1, "one", "id1"))
                       or take_acks() or handled.uuids == ["one"], 10, interval=0.02)
            for frames in (_frames(session, 3, 1, "three", "id3"),  # a gap: waits for 2
                           _frames(session, 1, 1, "one", "id1"),
                           _frames(session, 2, 1, "two", "id2"),
                           _frames(session, 2, 1, "two", "id2"),
                           _frames(session, 4, 1, "four", "id4")):
                raw.send_frames(frames)
            wait_until(lambda: take_acks() or handled.uuids[-1:] == ["four"], 10)
            # The same message id under another session (a restarted sender) is not re-run.
            other = os.urandom(16)
            raw.send_frames(_frames(other, 1, 1, "one-again", "id1"))
            raw.send_frames(_frames(other, 2, 1, "five", "id5"))
            wait_until(lambda: take_acks() or handled.uuids[-1:] == ["five"], 10)
            assert handled.uuids == ["one", "two", "three", "four", "five"]
            assert rx.handled == 5
            assert rx.sessions == 2
        watermarks = {}
        while acks.poll(100):
            take_acks()
        for _, payload in seen:
            sess, mark = wire.unpack_ack(payload)
            watermarks[sess] = max(watermarks.get(sess, 0), mark)
        assert watermarks == {session: 4, other: 2}
    finally:
        acks.close(0)
        forget_member(member)


def test_malformed_reliable_messages_are_dropped_without_blocking_the_channel(
    ep: BusEndpoints, raw: Publisher,
) -> None:
    handled = Handled()
    session = os.urandom(16)
    with ReliableReceiver(ep, src="rx", handler=handled) as rx:
        wait_until(lambda: raw.send_frames(_frames(session, 1, 1, "one", "id1"))
                   or handled.uuids == ["one"], 10, interval=0.02)
        topic, payload = _frames(session, 2, 1, "x", "id2")[1:3]
        raw.send_frames([wire.data_topic("action"), topic, payload[:-3],
                         wire.pack_header(session, 2, 1)])  # truncated envelope
        raw.send_frames([wire.data_topic("action"), topic, payload, b"short header"])
        raw.send_frames([wire.data_topic("action"), topic])
        raw.send_frames(_frames(session, 3, 1, "three", "id3"))
        wait_until(lambda: handled.uuids[-1:] == ["three"], 10)
        assert handled.uuids == ["one", "three"]
        assert rx.dropped == 3


def test_a_failing_handler_is_logged_and_not_run_again(ep: BusEndpoints) -> None:
    handled = Handled(fail_on="u1")
    with ReliableReceiver(ep, src="rx", handler=handled), ReliableSender(ep, src="tx") as tx:
        for n in range(3):
            tx.send(_request(f"u{n}"))
        assert tx.flush(timeout=10)
    assert handled.uuids == ["u0", "u1", "u2"]


def test_receiver_memory_of_senders_is_bounded(ep: BusEndpoints) -> None:
    handled = Handled()
    with ReliableReceiver(ep, src="rx", handler=handled, max_sessions=3) as rx:
        for n in range(8):
            with ReliableSender(ep, src=f"tx{n}") as tx:
                tx.send(_request(f"u{n}"))
                assert tx.flush(timeout=10)
        assert rx.sessions == 3
    assert handled.uuids == [f"u{n}" for n in range(8)]


def test_channels_are_separate(ep: BusEndpoints) -> None:
    actions, controls = Handled(), []
    with ReliableReceiver(ep, src="rx", channel="action", handler=actions), \
            ReliableReceiver(ep, src="rx", channel="control",
                             handler=lambda env: controls.append(env.body)), \
            ReliableSender(ep, src="tx", channel="control") as tx:
        tx.send(ActionControl(command="cancel", target="u1"))
        assert tx.flush(timeout=10)
    assert controls == [ActionControl(command="cancel", target="u1")]
    assert actions.uuids == []


def test_bad_channel_names_and_closed_senders_are_errors(ep: BusEndpoints) -> None:
    with pytest.raises(ConfigError, match="channel name"):
        ReliableSender(ep, src="tx", channel="a.b")
    tx = ReliableSender(ep, src="tx")
    tx.close()
    with pytest.raises(BusError, match="closed"):
        tx.send(_request("late"))


def test_a_monitor_sees_reliable_messages_as_ordinary_envelopes(ep: BusEndpoints) -> None:
    handled = Handled()
    with Subscriber(ep, prefixes=[""]) as monitor:
        assert monitor.wait_connected(5)
        with ReliableReceiver(ep, src="rx", handler=handled), \
                ReliableSender(ep, src="tx") as tx:
            msg_id = tx.send(_request("u1"))
            assert tx.flush(timeout=10)
            # The sender's next message is the end marker: u1, repeats included, is in
            # before it (u1's acks came back before it was sent).
            end_id = tx.send(_request("end"))
            assert tx.flush(timeout=10)
        seen = receive_until(monitor, lambda got: end_id in {env.id for env in got},
                             what="the end marker")
    assert seen[-1].body == _request("end")
    assert msg_id in {env.id for env in seen[:-1]}
    assert all(env.topic == "action.request" and env.body == _request("u1")
               for env in seen[:-1])
    assert monitor.dropped == 0  # acks and the channel's framing are not "malformed"


def test_a_message_the_handler_cannot_take_yet_is_repeated_until_it_can_in_order(
        ep: BusEndpoints) -> None:
    """NotHandled (a journal that cannot be written): no ack, the sender repeats it, and
    it is handled once, before the messages sent after it."""
    handled = Handled()
    refusals = [3]  # u1 is refused three times (as while the disk is full)

    def handler(env: Envelope) -> None:
        assert isinstance(env.body, ActionRequest)
        if env.body.uuid == "u1" and refusals[0] > 0:
            refusals[0] -= 1
            raise NotHandled("journal full")
        handled(env)

    with ReliableReceiver(ep, src="rx", handler=handler) as rx, \
            ReliableSender(ep, src="tx", resend_after=0.05, max_resend_after=0.1) as tx:
        for n in range(5):
            tx.send(_request(f"u{n}"))
        assert tx.flush(timeout=20)
        assert rx.held_back == 3 and refusals == [0]
    assert handled.uuids == ["u0", "u1", "u2", "u3", "u4"]
