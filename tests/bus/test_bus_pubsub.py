"""Publisher and Subscriber through a real proxy: filters, bad input, threads, loopback."""

from __future__ import annotations

import logging
import math
import sys
import threading
from pathlib import Path

import msgpack
import psutil
import pytest
import zmq

from mrss.bus import BusEndpoints, Publisher, Subscriber, publisher
from mrss.bus.publisher import MAX_BATCH
from mrss.bus.wire import WELCOME
from mrss.errors import BusError
from mrss.messages import (
    Envelope,
    Heartbeat,
    LogRecord,
    Message,
    Percept,
    RobotData,
    RobotState,
    encode,
)
from mrss.testing import wait_until
from tests.bus.bus_helpers import drain_until, sync


def _robot_sync(k: int) -> RobotData:
    return RobotData(robot="a", data={"sync": k})


def _is_sync(env: Envelope) -> bool:
    return isinstance(env.body, RobotData) and "sync" in env.body.data


def _drain(sub: Subscriber, *ends: Message) -> list[Envelope]:
    """Everything `sub` receives up to its publisher's end marker(s) `ends` (sync messages
    and the markers left out)."""
    return [env for env in drain_until(sub, *ends)
            if not _is_sync(env) and env.body not in ends]


def test_prefix_filters_deliver_only_matching_topics(proxy_thread: BusEndpoints) -> None:
    ep = proxy_thread
    with Publisher(ep, src="t") as pub, \
            Subscriber(ep, prefixes=["robot.a."]) as only_a, \
            Subscriber(ep, prefixes=["robot."]) as robots, \
            Subscriber(ep, prefixes=["robot.b.", "log."]) as b_and_logs, \
            Subscriber(ep) as everything:
        for sub in (only_a, robots, everything):
            sync(pub, sub, _robot_sync)
        sync(pub, b_and_logs, lambda k: RobotData(robot="b", data={"sync": k}))

        sent = [RobotData(robot="a", data={"n": 1}), RobotData(robot="b", data={"n": 2}),
                Percept(literal="fire(x)"), LogRecord(component="c", level="INFO", message="m"),
                RobotData(robot="ab", data={"n": 3})]
        for msg in sent:
            pub.publish(msg)
        end_a = RobotData(robot="a", data={"end": True})  # for robot.a. and robot.
        end_log = LogRecord(component="c", level="INFO", message="end")  # for log. and ""
        pub.publish(end_a)
        pub.publish(end_log)

        def got(sub: Subscriber, end: Message) -> list[object]:
            return [env.body for env in _drain(sub, end) if env.body != end_a]

        assert got(only_a, end_a) == [sent[0]]
        assert got(robots, end_a) == [sent[0], sent[1], sent[4]]
        assert got(b_and_logs, end_log) == [sent[1], sent[3]]
        assert got(everything, end_log) == sent


def test_malformed_messages_are_logged_and_dropped(
    proxy_thread: BusEndpoints, caplog: pytest.LogCaptureFixture,
) -> None:
    ep = proxy_thread
    with Publisher(ep, src="t") as pub, Subscriber(ep, name="watcher") as sub:
        sync(pub, sub, _robot_sync)
        _, percept = encode(Percept(literal="fire(x)"), src="t")
        garbage = [
            [b"robot.a.data", b"\xc1not msgpack"],
            [b"\xff\xfe", percept],
            [b"rel.action.msg", percept],  # reliable framing with a frame missing
            [b"robot.a.data", percept],  # a percept on a robot topic
            [b"percept", msgpack.packb({"v": 1})],
            [b"robot.lonely"],
        ]
        caplog.set_level(logging.WARNING, logger="mrss.bus")
        for frames in garbage:
            pub.send_frames(frames)
        final = Heartbeat(component="after", pid=1)
        pub.publish(final)

        assert [env.body for env in drain_until(sub, final) if not _is_sync(env)] == [final]
        assert sub.dropped == len(garbage)
        drops = [r.getMessage() for r in caplog.records if "malformed" in r.getMessage()]
        assert len(drops) == len(garbage)
        assert "watcher: dropped malformed message on topic 'robot.a.data': not msgpack" \
            in drops[0]
        assert "unexpected message of 2 frame(s)" in drops[2]
        assert "does not belong on this topic" in drops[3]
        assert "lacks 'id'" in drops[4]


def test_a_batch_delivers_its_messages_in_order_and_drops_only_bad_ones(
    proxy_thread: BusEndpoints,
) -> None:
    ep = proxy_thread
    with Publisher(ep, src="t") as pub, Subscriber(ep, prefixes=["percept"]) as sub:
        sync(pub, sub, lambda k: Percept(literal=f"sync({k})"))
        frames = [encode(Percept(literal=f"p{n}"), src="t")[1] for n in range(3)]
        pub.send_frames([b"percept", frames[0], b"\xc1", frames[1], frames[2]])
        end = Percept(literal="end")
        pub.publish(end)
        got = [env.body.literal for env in _drain(sub, end)]  # type: ignore[attr-defined]
        assert got == ["p0", "p1", "p2"]
        assert sub.dropped == 1


def test_skipped_topics_are_never_decoded_and_the_rest_of_the_prefix_arrives(
        proxy_thread: BusEndpoints) -> None:
    ep = proxy_thread
    def data(topic: bytes) -> bool:
        return topic.endswith(b".data")

    with Publisher(ep, src="t") as pub, \
            Subscriber(ep, prefixes=["robot."], skip=data) as states:
        sync(pub, states, lambda k: RobotState(robot=f"sync{k}", available=True))
        for n in range(3):
            pub.publish(RobotData(robot="a", data={"n": n}))
        frames = [encode(RobotData(robot="b", data={"n": n}), src="t", msg_id=f"t-{n}")
                  for n in range(5)]
        pub.send_frames([frames[0][0], *(payload for _, payload in frames)])  # a batch
        pub.send_frames([b"robot.c.data", b"\xc1 not msgpack"])
        pub.publish(RobotState(robot="a", available=False, reason="link down"))
        # The first message delivered is the last one published: nothing before it was.
        env = states.recv(timeout=10)
        assert env is not None and env.body == RobotState(robot="a", available=False,
                                                          reason="link down")
        assert (states.skipped, states.dropped) == (3 + 5 + 1, 0)


def test_a_gathering_sends_one_topics_messages_as_one_batch_and_holds_nothing_else(
        proxy_thread: BusEndpoints) -> None:
    ep = proxy_thread
    with Publisher(ep, src="t") as pub, Subscriber(ep, prefixes=["robot.", "log."]) as sub:
        sync(pub, sub, _robot_sync)
        before = pub.sends
        with pub.gathering():
            for n in range(3):
                pub.publish(RobotData(robot="a", data={"n": n}))
            assert pub.sends == before  # held
            # another thread is not held: its message arrives while the block is open
            other = threading.Thread(target=pub.publish, args=(
                LogRecord(component="c", level="INFO", message="other thread"),))
            other.start()
            other.join()
            env = sub.recv(timeout=10)
            assert env is not None and env.body.message == "other thread"  # type: ignore[attr-defined]
        assert pub.sends == before + 2  # the log record, then the three records as one
        assert _receive(sub, 3) == [0, 1, 2]
        # a message on another topic sends the held ones first and goes at once
        with pytest.raises(RuntimeError), pub.gathering():
            pub.publish(RobotData(robot="a", data={"n": 3}))
            pub.publish(LogRecord(component="c", level="INFO", message="request"))
            seen = sub.recv(timeout=10), sub.recv(timeout=10)
            pub.publish(RobotData(robot="a", data={"n": 4}))
            raise RuntimeError("the block ends by an exception")
        assert [getattr(e.body, "data", None) or e.body.message for e in seen  # type: ignore
                if e is not None] == [{"n": 3}, "request"]
        assert _receive(sub, 1) == [4]  # sent at the end, exception or not


def test_a_burst_is_batched_and_arrives_whole_and_in_order(
        proxy_thread: BusEndpoints, monkeypatch: pytest.MonkeyPatch) -> None:
    ep = proxy_thread
    count = 5000
    with Publisher(ep, src="t") as pub, Subscriber(ep, prefixes=["robot."]) as sub:
        sync(pub, sub, _robot_sync)
        pub.flush()
        before = pub.sends
        # The rule, not this machine's speed: with these windows every publish of the
        # loop follows the previous one within BURST_GAP, so a batch goes out when full
        # (MAX_BATCH), or cut short only by a stall of FLUSH_IDLE or MAX_HOLD; the
        # flusher sends the tail by MAX_HOLD after its batch began.
        monkeypatch.setattr(publisher, "BURST_GAP", 60.0)
        monkeypatch.setattr(publisher, "MAX_HOLD", 1.0)
        monkeypatch.setattr(publisher, "FLUSH_IDLE", 0.5)
        for n in range(count):
            pub.publish(RobotData(robot="b", data={"n": n}))
        # Not flushed by hand: the flusher sends the tail of the burst by itself.
        got = _receive(sub, count)
        assert got == list(range(count))
        sent = pub.sends - before
        assert math.ceil(count / MAX_BATCH) <= sent <= count // 2, sent
        assert pub.batches_sent >= 1
        end = RobotData(robot="b", data={"end": True})
        pub.publish(end)
        env = sub.recv(timeout=10)
        assert env is not None and env.body == end  # nothing twice before it


def test_a_batch_on_the_wire_is_delivered_as_its_messages_in_order(
        proxy_thread: BusEndpoints) -> None:
    ep = proxy_thread
    with Publisher(ep, src="t") as pub, Subscriber(ep, prefixes=["robot."]) as sub:
        sync(pub, sub, _robot_sync)
        frames = [encode(RobotData(robot="b", data={"n": n}), src="t", msg_id=f"t-{n}")
                  for n in range(MAX_BATCH)]
        pub.send_frames([frames[0][0], *(payload for _, payload in frames)])  # one batch
        assert _receive(sub, MAX_BATCH) == list(range(MAX_BATCH))


def _receive(sub: Subscriber, count: int) -> list[int]:
    """The `n` of the next `count` robot data messages (sync messages skipped)."""
    got: list[int] = []
    while len(got) < count:
        env = sub.recv(timeout=10)
        assert env is not None, f"only {len(got)} of {count} messages arrived"
        if not _is_sync(env):
            got.append(env.body.data["n"])  # type: ignore[attr-defined]
    return got


def test_publisher_is_thread_safe(proxy_thread: BusEndpoints) -> None:
    ep = proxy_thread
    threads, per_thread = 4, 2000
    with Publisher(ep, src="t") as pub, Subscriber(ep, prefixes=["robot."]) as sub:
        sync(pub, sub, _robot_sync)

        def publish_many(robot: str) -> None:
            for n in range(per_thread):
                pub.publish(RobotData(robot=robot, data={"n": n}))

        workers = [threading.Thread(target=publish_many, args=(f"r{i}",)) for i in range(threads)]
        for w in workers:
            w.start()
        received: list[Envelope] = []
        while len(received) < threads * per_thread:
            env = sub.recv(timeout=5)
            assert env is not None, f"only {len(received)} messages arrived"
            if not _is_sync(env):
                received.append(env)
        for w in workers:
            w.join()
        assert len({env.id for env in received}) == threads * per_thread
        for i in range(threads):
            ns = [e.body.data["n"] for e in received if e.topic == f"robot.r{i}.data"]  # type: ignore[attr-defined]
            assert ns == list(range(per_thread))


def test_callback_thread_survives_a_failing_callback_and_stops_on_close(
    proxy_thread: BusEndpoints,
) -> None:
    ep = proxy_thread
    seen: list[str] = []

    def callback(env: Envelope) -> None:
        assert isinstance(env.body, Percept)
        seen.append(env.body.literal)
        if env.body.literal == "boom":
            raise RuntimeError("callback bug")

    with Publisher(ep, src="t") as pub:
        sub = Subscriber(ep, prefixes=["percept"])
        sub.start(callback)
        try:
            wait_until(lambda: pub.publish(Percept(literal="hello")) and "hello" in seen, 10,
                       interval=0.02)
            pub.publish(Percept(literal="boom"))
            pub.publish(Percept(literal="after"))
            wait_until(lambda: "after" in seen, 5, message="delivery after a failing callback")
            assert seen.index("boom") < seen.index("after")
        finally:
            sub.close()
        with pytest.raises(BusError):
            sub.recv(timeout=0)
        with pytest.raises(BusError, match="closed"):
            sub.start(callback)


def test_iteration_ends_when_closed_from_another_thread(proxy_thread: BusEndpoints) -> None:
    sub = Subscriber(proxy_thread)
    finished = threading.Event()

    def iterate() -> None:
        for _ in sub:
            pass
        finished.set()

    thread = threading.Thread(target=iterate)
    thread.start()
    sub.close()
    assert finished.wait(5)
    thread.join()


def test_recv_returns_none_after_its_timeout(proxy_thread: BusEndpoints) -> None:
    with Subscriber(proxy_thread, prefixes=["nothing."]) as sub:
        assert sub.wait_connected(5)
        assert sub.recv(timeout=0.05) is None
        assert sub.recv(timeout=0) is None


def test_publisher_knows_when_the_proxy_has_joined(proxy_thread: BusEndpoints) -> None:
    with Publisher(proxy_thread, src="t") as pub:
        assert pub.wait_connected(5)


def test_publisher_without_a_proxy_is_not_connected() -> None:
    ep = BusEndpoints.tcp_loopback()
    with Publisher(ep, src="t", linger=0) as pub:
        assert not pub.wait_connected(0.2)
        pub.publish(Percept(literal="queued"))  # no proxy: queued, never an error
    with pytest.raises(BusError, match="closed"):
        pub.publish(Percept(literal="late"))


@pytest.mark.parametrize("endpoints", ["tcp"], indirect=True)
def test_tcp_bus_listens_on_loopback_only(proxy_thread: BusEndpoints) -> None:
    ep = proxy_thread
    listening = [c.laddr for c in psutil.Process().net_connections(kind="tcp")
                 if c.status == psutil.CONN_LISTEN]
    ports = {int(e.rsplit(":", 1)[1]) for e in (ep.frontend, ep.backend)}
    assert {addr.port for addr in listening} >= ports
    assert {addr.ip for addr in listening if addr.port in ports} == {"127.0.0.1"}
    with Publisher(ep, src="t") as pub, Subscriber(ep, prefixes=["robot."]) as sub:
        sync(pub, sub, _robot_sync)


def test_an_isolated_message_is_sent_at_once_not_held_for_a_batch(
    proxy_thread: BusEndpoints,
) -> None:
    with Publisher(proxy_thread, src="t") as pub, \
            Subscriber(proxy_thread, prefixes=["robot."]) as sub:
        sync(pub, sub, _robot_sync)  # its last publish was a receive timeout or more ago
        pub.flush()  # a loaded machine may not have flushed sync's last burst yet
        before = pub.sends
        pub.publish(RobotData(robot="a", data={"alone": True}))
        assert pub.sends == before + 1


def test_a_new_publishers_first_messages_are_held_until_the_proxy_joins(
        proxy_thread: BusEndpoints) -> None:
    ep = proxy_thread
    with Subscriber(ep, prefixes=["log."]) as sub:
        assert sub.wait_connected(timeout=10)
        with Publisher(ep, src="fresh") as pub:
            # no wait_connected: these go out before the proxy has subscribed to `pub`
            for n in range(5):
                pub.publish(LogRecord(component="fresh", level="INFO", message=str(n)))
            end = LogRecord(component="fresh", level="INFO", message="end")
            pub.publish(end)
            got = [env.body.message for env in _drain(sub, end)
                   if isinstance(env.body, LogRecord)]
    assert got == ["0", "1", "2", "3", "4"]



def test_publishing_is_not_blocked_by_a_thread_waiting_for_the_proxy() -> None:
    # Regression: wait_connected held the publisher's lock while it polled (50 ms slices),
    # so a root supervisor's sup.* publish, with the joiner waiting for an absent proxy,
    # stalled its loop long enough to call healthy components hung.
    ep = BusEndpoints.tcp_loopback()  # no proxy: the waiter waits its whole timeout
    with Publisher(ep, src="t", linger=0) as pub:
        results: list[bool] = []
        thread = threading.Thread(
            target=lambda: results.append(pub.wait_connected(timeout=2.0)), daemon=True)
        thread.start()

        def waiting() -> bool:  # the waiter is inside wait_connected (or gave up)
            frame = sys._current_frames().get(thread.ident or 0)
            return frame is None or frame.f_code.co_name == "wait_connected"

        for n in range(200):  # each publish comes while the waiter waits
            wait_until(waiting, timeout=10, message="waiter in wait_connected")
            pub.publish(Percept(literal=f"held({n})"))
        assert thread.is_alive()  # all 200 returned within the waiter's 2 s
        thread.join(10)
    assert results == [False]


def test_a_bound_publisher_is_not_connected_by_a_welcome_subscription_alone(
        run_dir: Path) -> None:
    # A subscriber's welcome topic sorts first and can reach the publisher before its
    # prefixes: what the publisher held must wait for a prefix, or it goes to nobody.
    at = f"ipc://{run_dir}/bound.sock"
    with Publisher(BusEndpoints(at, f"ipc://{run_dir}/unused.sock"), src="b",
                   bind=True, watch_subscriptions=True) as pub:
        sock = zmq.Context.instance().socket(zmq.SUB)
        try:
            sock.connect(at)
            sock.setsockopt(zmq.SUBSCRIBE, WELCOME)
            pub.publish(RobotData(robot="r", data={"n": 0}))
            wait_until(lambda: WELCOME.decode() in pub.subscriptions(), timeout=10,
                       message="the welcome subscription at the publisher")
            assert not pub.wait_connected(0.2)
            sock.setsockopt(zmq.SUBSCRIBE, b"robot.")
            assert pub.wait_connected(10)
            assert sock.poll(10_000), "the held message never came"
            topic, payload = sock.recv_multipart()
            assert topic == b"robot.r.data" and msgpack.unpackb(payload)["body"]["data"] == {"n": 0}
        finally:
            sock.close(0)


def test_a_bound_publisher_delivers_once_a_subscriber_connected_to_it(run_dir: Path) -> None:
    # No proxy: the publisher binds, the subscriber connects there (bench bus "no proxy").
    at = f"ipc://{run_dir}/bound.sock"
    with Publisher(BusEndpoints(at, f"ipc://{run_dir}/unused.sock"), src="b", bind=True) as pub, \
            Subscriber(BusEndpoints(f"ipc://{run_dir}/unused.sock", at),
                       prefixes=["robot."]) as sub:
        pub.publish(RobotData(robot="r", data={"n": 0}))  # held until it subscribed
        assert pub.wait_connected(5)
        pub.publish(RobotData(robot="r", data={"n": 1}))
        assert _receive(sub, 2) == [0, 1]
