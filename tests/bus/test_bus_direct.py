"""Direct delivery (mrss/bus/direct.py) through real processes and sockets: what only a
direct bus does. The rest of the bus tests run on a direct bus too (the `-direct`
endpoints of conftest.py)."""

from __future__ import annotations

import time
from pathlib import Path

import msgpack
import pytest
import zmq

from mrss.bus import BusEndpoints, ProxyThread, Publisher, Subscriber
from mrss.bus.direct import MARKER, MEMBER, subscriber_socket
from mrss.bus.introducer import GRACE, Introducer
from mrss.bus.settings import endpoints_from_config
from mrss.errors import ConfigError
from mrss.messages import Percept, RobotData
from mrss.testing import wait_until
from tests.bus.bus_helpers import Spawn, drain_until


def _percept(k: int) -> Percept:
    return Percept(literal=f"p({k})")


@pytest.fixture()
def direct_ipc(run_dir: Path) -> BusEndpoints:
    return BusEndpoints.ipc(run_dir, direct=True)


def test_first_words_and_every_message_after_go_to_each_member_once_in_order(
        direct_ipc: BusEndpoints) -> None:
    ep = direct_ipc
    with ProxyThread(ep), Subscriber(ep, prefixes=["percept"]) as early:
        assert early.wait_connected(5)
        with Publisher(ep, src="p") as pub:
            for k in range(200):  # before anyone joined: held, then delivered
                pub.publish(_percept(k))
            assert pub.wait_connected(5)  # introduced, and every member joined
            # The tail of that burst may still sit in an open batch (its flusher thread
            # starved on a loaded machine): sent after `late` joined, it would reach
            # `late` too, as on a proxy bus. What `late` must get is what follows its join.
            pub.flush()
            with Subscriber(ep, prefixes=["percept"]) as late:
                assert late.wait_connected(5)
                for k in range(200, 400):
                    pub.publish(_percept(k))
                end = _percept(400)
                pub.publish(end)
                assert [e.body.literal for e in drain_until(early, end)] == \
                    [f"p({k})" for k in range(401)]
                assert [e.body.literal for e in drain_until(late, end)] == \
                    [f"p({k})" for k in range(200, 401)]


def test_the_proxy_carries_no_messages_and_its_death_does_not_stop_them(
        spawn: Spawn, direct_ipc: BusEndpoints) -> None:
    ep = direct_ipc
    proxy = spawn(ep, "proxy")
    with Subscriber(ep, prefixes=["percept"]) as sub, Publisher(ep, src="p") as pub:
        assert sub.wait_connected(5) and pub.wait_connected(5)
        proxy.kill()
        for k in range(100):  # no proxy at all now
            pub.publish(_percept(k))
        got = drain_until(sub, _percept(99))
        assert [e.body.literal for e in got] == [f"p({k})" for k in range(100)]
        spawn(ep, "proxy")  # a new member needs it again
        with Subscriber(ep, prefixes=["percept"]) as newcomer:
            assert newcomer.wait_connected(10)
            pub.publish(_percept(100))
            env = newcomer.recv(timeout=5)
            assert env is not None and env.body.literal == "p(100)"


def test_a_member_killed_is_forgotten_by_publishers_and_its_file_removed(
        spawn: Spawn, direct_ipc: BusEndpoints, run_dir: Path) -> None:
    ep = direct_ipc
    spawn(ep, "proxy")
    peer = spawn(ep, "sub", "robot.")
    with Publisher(ep, src="p") as pub:
        assert pub.wait_connected(5)
        route = pub._route
        assert route is not None
        wait_until(lambda: route.members == 1, 10, message="the peer joined")
        files = list(run_dir.glob("bus-m-*.sock"))
        assert len(files) == 1
        peer.kill()  # SIGKILL, and reaped (as its supervisor would)
        wait_until(lambda: pub.flush() or route.members == 0, 10,
                   message="the killed member forgotten")
        # Its file stays until the next member binds beside it, which removes it.
        with Subscriber(ep, prefixes=["robot."]) as sub:
            assert sub.wait_connected(5)
            assert not files[0].exists()
            pub.publish(RobotData(robot="r1", data={"seq": 1}))
            assert sub.recv(timeout=5) is not None
        assert list(run_dir.glob("bus-m-*.sock")) == []  # closed members remove theirs


def test_a_malformed_membership_is_ignored_and_others_still_served(
        direct_ipc: BusEndpoints, caplog: pytest.LogCaptureFixture) -> None:
    ep = direct_ipc
    ctx = zmq.Context.instance()
    with ProxyThread(ep), Publisher(ep, src="p") as pub:
        assert pub.wait_connected(5)
        bad = ctx.socket(zmq.SUB)
        bad.connect(ep.backend)
        for junk in (MEMBER + b"\xc1not msgpack", MEMBER + msgpack.packb([1, 2, 3]),
                     MEMBER + msgpack.packb(["ipc:///nonexistent/x.sock", ["a"], -5])):
            bad.setsockopt(zmq.SUBSCRIBE, junk)
        try:
            with Subscriber(ep, prefixes=["percept"]) as sub:
                assert sub.wait_connected(5)
                pub.publish(_percept(1))
                env = sub.recv(timeout=5)
                assert env is not None and env.body.literal == "p(1)"
            assert "ignored a malformed membership" in caplog.text
            assert pub._route is not None and pub._route.ready
        finally:
            bad.close(0)


def test_a_subscriber_not_told_the_bus_is_direct_joins_when_greeted(run_dir: Path) -> None:
    direct, plain = BusEndpoints.ipc(run_dir, direct=True), BusEndpoints.ipc(run_dir)
    with ProxyThread(direct), Subscriber(plain, prefixes=["percept"]) as sub, \
            Publisher(plain, src="tool") as pub:
        assert sub.wait_connected(5)  # the direct welcome: it binds, then is answered
        pub.publish(_percept(1))  # the publisher learns it from the proxy's marker
        env = sub.recv(timeout=5)
        assert env is not None and env.body.literal == "p(1)"


def test_a_raw_member_socket_joins_while_it_reads_itself(direct_ipc: BusEndpoints) -> None:
    ep = direct_ipc
    with ProxyThread(ep), Publisher(ep, src="p") as pub:
        sock, member = subscriber_socket(zmq.Context.instance(), ep, [b"percept"])
        try:
            def arrived() -> bool:
                pub.publish(_percept(1))
                while sock.poll(20):
                    if sock.recv_multipart()[0] == b"percept":
                        return True
                return False
            wait_until(arrived, 10, interval=0.01, message="a message on the raw member")
        finally:
            sock.close(0)
            assert member is not None and member.startswith("ipc://")


def test_delivery_is_a_bus_key_and_direct_is_for_one_host(tmp_path: Path) -> None:
    assert endpoints_from_config({"delivery": "direct"}, tmp_path).direct
    assert not endpoints_from_config({}, tmp_path).direct  # the declared default: proxy
    assert not endpoints_from_config({"delivery": "proxy"}, tmp_path).direct
    # On [nodes] the nodes' proxies link the hosts: through them unless the table says.
    assert not endpoints_from_config({}, tmp_path, nodes=True).direct
    assert endpoints_from_config({"delivery": "direct"}, tmp_path, nodes=True).direct
    with pytest.raises(ConfigError, match="'proxy' or 'direct'"):
        endpoints_from_config({"delivery": "fast"}, tmp_path, file="project.toml")
    with pytest.raises(ConfigError, match="one host"):
        endpoints_from_config({"delivery": "direct", "transport": "tcp", "host": "10.1.2.3",
                               "frontend_port": 5601, "backend_port": 5602}, tmp_path)
    ep = BusEndpoints.tcp("127.0.0.1", 5601, 5602, direct=True)
    assert BusEndpoints.from_dict(ep.to_dict()) == ep
    assert "direct" not in BusEndpoints.ipc(tmp_path).to_dict()  # as before for the rest


def test_a_publisher_made_before_the_proxy_goes_direct_whatever_it_hears_first(
        spawn: Spawn, direct_ipc: BusEndpoints) -> None:
    # Members' subscriptions (the welcome topic sorts first) can reach a publisher before
    # the proxy's marker, the more so the more there are: it must not take them for a
    # plain proxy and send through it (where nothing is forwarded).
    ep = direct_ipc
    prefixes = [f"percept.{'x' * 40}.{k}" for k in range(20)] + ["percept"]
    with Publisher(ep, src="p") as pub:
        pub.publish(_percept(0))  # held: nobody introduced it yet
        proxy = spawn(ep, "proxy")
        subs = [Subscriber(ep, prefixes=prefixes) for _ in range(30)]
        try:
            assert all(sub.wait_connected(10) for sub in subs)
            assert pub.wait_connected(10) and pub._route is not None
            pub.publish(_percept(1))
            for sub in subs:  # the first words, then what followed, each once
                assert [e.body.literal for e in drain_until(sub, _percept(1))] == \
                    ["p(0)", "p(1)"]
            proxy.kill()  # and again, reconnecting to a proxy that has them all
            spawn(ep, "proxy")
            with Publisher(ep, src="q") as late:
                assert late.wait_connected(10) and late._route is not None
                late.publish(_percept(2))
                for sub in subs:
                    assert [e.body.literal for e in drain_until(sub, _percept(2))] == ["p(2)"]
        finally:
            for sub in subs:
                sub.close()


def test_mrss_record_given_only_a_run_dir_joins_a_direct_bus(run_dir: Path) -> None:
    import threading

    from mrss.recording.recorder import BusRecorder  # the recorder behind `mrss record`

    direct, plain = BusEndpoints.ipc(run_dir, direct=True), BusEndpoints.ipc(run_dir)
    with ProxyThread(direct), Publisher(plain, src="p") as pub:
        rec = BusRecorder(plain, ["percept"])
        try:
            assert rec.wait_connected(10, threading.Event())  # joined, then answered
            pub.publish(_percept(1))
            assert rec._sock.poll(5000)
            assert rec._sock.recv_multipart()[0] == b"percept"
        finally:
            rec.close()
    assert list(run_dir.glob("bus-m-*.sock")) == []


def test_a_member_forgotten_and_learnt_again_keeps_getting_messages(
        direct_ipc: BusEndpoints) -> None:
    """The proxy withdraws a membership and gives it again (the member's link to the
    proxy dropped and came back): the publisher disconnects, then connects anew, and the
    echo of its own disconnect, read later, must not undo the new link."""
    ep = direct_ipc
    with ProxyThread(ep), Subscriber(ep, prefixes=["percept"]) as sub, \
            Publisher(ep, src="p") as pub:
        assert sub.wait_connected(5) and pub.wait_connected(5)
        route = pub._route
        assert route is not None
        membership = b"\x01" + sub._membership
        with pub._lock:  # as the proxy's notices would arrive: withdrawn, then given
            route.on_control(b"\x00" + membership[1:])
            route.on_control(membership)
        assert pub.wait_connected(5)  # joined again
        for k in range(50):  # meanwhile the watcher reads the old link's leave
            pub.publish(_percept(k))
            assert sub.recv(timeout=5) is not None, f"message {k} lost after the relearn"
        assert route.members == 1


def test_a_fresh_direct_proxy_introduces_at_once_and_a_restarted_one_waits() -> None:
    """A restarted proxy waits GRACE for its clients to reconnect before its marker; the
    first on its endpoints has none to wait for, and its marker goes out at its start."""
    ctx = zmq.Context.instance()
    sockets_made: list[zmq.Socket[bytes]] = []

    def proxy_and_publisher(name: str) -> tuple[zmq.Socket[bytes], zmq.Socket[bytes],
                                                zmq.Socket[bytes]]:
        frontend, backend, publisher = (ctx.socket(zmq.XSUB), ctx.socket(zmq.XPUB),
                                        ctx.socket(zmq.XPUB))
        sockets_made.extend((frontend, backend, publisher))
        frontend.bind(f"inproc://{name}-front")
        backend.bind(f"inproc://{name}-back")
        publisher.connect(f"inproc://{name}-front")
        return frontend, backend, publisher

    try:
        frontend, backend, publisher = proxy_and_publisher("fresh")
        Introducer(frontend, backend, fresh=True).look()
        assert publisher.poll(5000) and publisher.recv() == b"\x01" + MARKER
        frontend, backend, publisher = proxy_and_publisher("restarted")
        made = time.monotonic()
        restarted = Introducer(frontend, backend)
        assert restarted.marker_due is not None and restarted.marker_due >= made + GRACE
    finally:
        for sock in sockets_made:
            sock.close(0)
