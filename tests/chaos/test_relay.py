"""The campaign's relays on real sockets: what a network fault does to real traffic.

A UDP echo peer stands for the simulator (MAVLink), a TCP echo peer for the MQTT broker;
the client talks to the relay's address as the RCL's link (or the robot) would.
"""

from __future__ import annotations

import contextlib
import select
import socket
import threading
from collections.abc import Iterator

import pytest

from mrss.chaos.relay import Impairment, Impairments, TcpRelay, UdpRelay
from mrss.testing import wait_until


@pytest.fixture()
def udp_peer() -> Iterator[tuple[socket.socket, list[bytes]]]:
    """A UDP peer that records what it receives and echoes it."""
    sock = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
    sock.bind(("127.0.0.1", 0))
    got: list[bytes] = []
    stop = threading.Event()

    def serve() -> None:
        while not stop.is_set():
            if select.select([sock], [], [], 0.05)[0]:
                data, sender = sock.recvfrom(65535)
                got.append(data)
                sock.sendto(b"echo " + data, sender)
    thread = threading.Thread(target=serve, daemon=True)
    thread.start()
    yield sock, got
    stop.set()
    thread.join(timeout=5)
    sock.close()


def _udp(peer: socket.socket, hold: float = 0.15) -> tuple[UdpRelay, Impairments,
                                                           socket.socket]:
    impairments = Impairments(seed=3)
    relay = UdpRelay(lambda: peer.getsockname(), impairments)
    relay.hold = hold
    relay.start()
    client = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
    client.bind(("127.0.0.1", 0))
    client.settimeout(10)
    return relay, impairments, client


def test_udp_passes_both_ways_and_a_partition_cuts_until_healed(udp_peer) -> None:  # type: ignore[no-untyped-def]
    peer, got = udp_peer
    relay, impairments, client = _udp(peer)
    try:
        client.sendto(b"1", relay.address)
        assert client.recvfrom(100)[0] == b"echo 1"  # there and back through the relay
        heal = impairments.add(Impairment.PARTITION)
        client.sendto(b"2", relay.address)
        wait_until(lambda: relay.counts["dropped"] == 1, timeout=10, message="2 dropped")
        heal()
        heal()  # a heal counts once
        assert impairments.clear
        client.sendto(b"3", relay.address)
        assert client.recvfrom(100)[0] == b"echo 3"
        assert got == [b"1", b"3"]
    finally:
        relay.close()
        client.close()


def test_udp_loss_drops_some_and_the_rest_arrive(udp_peer) -> None:  # type: ignore[no-untyped-def]
    peer, got = udp_peer
    relay, impairments, client = _udp(peer)
    heal = impairments.add(Impairment.LOSS, 0.5)
    try:
        for n in range(200):
            client.sendto(b"%d" % n, relay.address)
        # each datagram either way is dropped or passed: 200 in, their echoes out
        wait_until(lambda: relay.counts["passed"] + relay.counts["dropped"]
                   == 200 + len(got), timeout=20, message="every datagram judged")
        assert 0 < len(got) < 200
        assert relay.counts["dropped"] > 0
    finally:
        heal()
        relay.close()
        client.close()


def test_udp_reorder_lets_a_later_datagram_overtake(udp_peer) -> None:  # type: ignore[no-untyped-def]
    peer, got = udp_peer
    relay, impairments, client = _udp(peer, hold=3600.0)  # held until the test lets go
    try:
        heal = impairments.add(Impairment.REORDER, 1.0)   # every datagram held back
        client.sendto(b"first", relay.address)
        wait_until(lambda: relay.counts["held"] == 1, timeout=10, message="first held")
        heal()
        client.sendto(b"second", relay.address)
        wait_until(lambda: got == [b"second"], timeout=10, message="second overtook")
        assert relay.counts["reordered"] == 1
    finally:
        relay.close()
        client.close()


def test_udp_delay_holds_and_then_delivers_in_order(udp_peer) -> None:  # type: ignore[no-untyped-def]
    peer, got = udp_peer
    relay, impairments, client = _udp(peer)
    heal = impairments.add(Impairment.DELAY, 0.2)
    try:
        for n in range(5):
            client.sendto(b"%d" % n, relay.address)
        wait_until(lambda: len(got) == 5, timeout=10, message="all delivered")
        assert got == [b"0", b"1", b"2", b"3", b"4"]  # one delay for all: order kept
        assert relay.counts["held"] >= 5 and relay.counts["reordered"] == 0
    finally:
        heal()
        relay.close()
        client.close()


@pytest.fixture()
def tcp_peer() -> Iterator[socket.socket]:
    """A TCP echo server."""
    server = socket.create_server(("127.0.0.1", 0))
    stop = threading.Event()

    def serve() -> None:
        server.settimeout(0.1)
        while not stop.is_set():
            try:
                conn, _ = server.accept()
            except TimeoutError:
                continue
            threading.Thread(target=_echo, args=(conn,), daemon=True).start()
    thread = threading.Thread(target=serve, daemon=True)
    thread.start()
    yield server
    stop.set()
    thread.join(timeout=5)
    server.close()


def _echo(conn: socket.socket) -> None:
    with conn, contextlib.suppress(ConnectionResetError):  # a relay's reset (loss)
        while data := conn.recv(4096):
            conn.sendall(data)


def test_tcp_partition_holds_bytes_until_healed_and_delay_passes_them(tcp_peer) -> None:  # type: ignore[no-untyped-def]
    impairments = Impairments()
    relay = TcpRelay(lambda: tcp_peer.getsockname(), impairments).start()
    client = socket.create_connection(relay.address, timeout=10)
    try:
        client.sendall(b"hello")
        assert client.recv(100) == b"hello"
        heal = impairments.add(Impairment.PARTITION)
        client.sendall(b"cut")
        # nothing comes back while the partition is on (the relay holds the bytes)
        assert select.select([client], [], [], 0.5)[0] == []
        heal()
        assert client.recv(100) == b"cut"  # the same connection, healed
        heal_delay = impairments.add(Impairment.DELAY, 0.1)
        client.sendall(b"slow")
        assert client.recv(100) == b"slow"
        heal_delay()
        assert relay.counts["connections"] == 1
    finally:
        client.close()
        relay.close()


def test_tcp_loss_stalls_chunks_and_passes_them_intact_in_order(tcp_peer) -> None:  # type: ignore[no-untyped-def]
    impairments = Impairments(seed=5)
    relay = TcpRelay(lambda: tcp_peer.getsockname(), impairments)
    relay.stall, relay.reset_share = 0.05, 0.0  # every chunk hit stalls, none resets
    relay.start()
    client = socket.create_connection(relay.address, timeout=10)
    try:
        heal = impairments.add(Impairment.LOSS, 1.0)
        got = b""
        for n in range(5):
            client.sendall(f"m{n};".encode())
            while not got.endswith(f"m{n};".encode()):
                got += client.recv(100)
        assert got == b"m0;m1;m2;m3;m4;"  # nothing lost, nothing out of order
        assert relay.counts["stalled"] >= 10  # each chunk, both ways
        assert relay.counts["reset"] == 0 and relay.counts["connections"] == 1
        heal()
        before = relay.counts["stalled"]
        client.sendall(b"clear")
        assert client.recv(100) == b"clear"
        assert relay.counts["stalled"] == before  # healed: no stall any more
    finally:
        client.close()
        relay.close()


def test_tcp_loss_may_reset_the_connection_and_a_new_one_passes(tcp_peer) -> None:  # type: ignore[no-untyped-def]
    impairments = Impairments(seed=5)
    relay = TcpRelay(lambda: tcp_peer.getsockname(), impairments)
    relay.reset_share = 1.0  # every chunk hit resets its connection
    relay.start()
    client = socket.create_connection(relay.address, timeout=10)
    try:
        client.sendall(b"before")
        assert client.recv(100) == b"before"
        heal = impairments.add(Impairment.LOSS, 1.0)
        client.sendall(b"lost")
        with pytest.raises(ConnectionResetError):
            while client.recv(100):  # the reset arrives (RST), the bytes never do
                pass
        assert relay.counts["reset"] == 1
        heal()
        again = socket.create_connection(relay.address, timeout=10)
        with again:
            again.sendall(b"after")
            assert again.recv(100) == b"after"
        assert relay.counts["connections"] == 2
    finally:
        client.close()
        relay.close()
