"""The node filter on real packets: two network namespaces joined by a veth pair.

NEEDS ROOT and `nft` (CI runs as root with nftables installed): without them the test
is skipped, unless MRSS_REQUIRE_NETNS=1, where it fails saying why. Namespace B runs a
UDP echo; a client in A sends numbered datagrams and counts the echoes (a datagram the
filter drops on its way out fails the send with EPERM: not an echo). The filter's
rules are set in A (`ip netns exec A nft ...`): a partition lets nothing through, its
heal everything again, a 30 % loss some but not all.
"""

from __future__ import annotations

import os
import shutil
import subprocess
import sys
import uuid
from collections.abc import Iterator

import pytest

from mrss.chaos.network import NodeFilter, why_no_nft

REQUIRE = os.environ.get("MRSS_REQUIRE_NETNS") == "1"
WHY_NOT = why_no_nft() or ("" if shutil.which("ip") else "the ip command is not installed")
if WHY_NOT and REQUIRE:
    pytest.fail(f"MRSS_REQUIRE_NETNS=1 but the node filter test cannot run: {WHY_NOT}",
                pytrace=False)
pytestmark = pytest.mark.skipif(bool(WHY_NOT), reason=WHY_NOT)

ECHO = ("import socket; s = socket.socket(socket.AF_INET, socket.SOCK_DGRAM); "
        "s.bind(('0.0.0.0', 7007)); print('ready', flush=True)\n"
        "while True:\n    d, a = s.recvfrom(100); s.sendto(d, a)")
CLIENT = ("import socket, sys; s = socket.socket(socket.AF_INET, socket.SOCK_DGRAM); "
          "s.settimeout(0.1); n = 0\n"
          "for i in range(int(sys.argv[2])):\n"
          "    try:\n        s.sendto(b'%d' % i, (sys.argv[1], 7007))\n"
          "        n += s.recv(100) == b'%d' % i\n"
          "    except OSError:\n        pass\n"
          "print(n)")


def ip(*args: str) -> None:
    subprocess.run(["ip", *args], check=True, capture_output=True, timeout=10)


@pytest.fixture()
def pair() -> Iterator[tuple[str, str]]:
    tag = uuid.uuid4().hex[:6]
    a, b = f"mrssnfa{tag}", f"mrssnfb{tag}"
    ip("netns", "add", a)
    ip("netns", "add", b)
    echo = None
    try:
        ip("link", "add", f"nfa{tag}", "netns", a, "type", "veth", "peer", "name",
           f"nfb{tag}", "netns", b)
        for ns, dev, addr in ((a, f"nfa{tag}", "10.231.7.1/24"),
                              (b, f"nfb{tag}", "10.231.7.2/24")):
            ip("-n", ns, "addr", "add", addr, "dev", dev)
            ip("-n", ns, "link", "set", dev, "up")
            ip("-n", ns, "link", "set", "lo", "up")
        echo = subprocess.Popen(["ip", "netns", "exec", b, sys.executable, "-c", ECHO],
                                stdout=subprocess.PIPE, text=True)
        assert echo.stdout is not None and echo.stdout.readline() == "ready\n"
        yield a, "10.231.7.2"
    finally:
        if echo is not None:
            echo.kill()
            echo.wait(timeout=10)
        for ns in (a, b):
            subprocess.run(["ip", "netns", "del", ns], capture_output=True, timeout=10)


def echoes(ns: str, address: str, count: int = 100) -> int:
    done = subprocess.run(["ip", "netns", "exec", ns, sys.executable, "-c", CLIENT,
                           address, str(count)], capture_output=True, text=True,
                          timeout=120, check=True)
    return int(done.stdout)


def test_a_partition_drops_every_packet_until_healed_and_loss_some(pair) -> None:  # type: ignore[no-untyped-def]
    ns, peer = pair
    nodes = NodeFilter(prefix=("ip", "netns", "exec", ns))
    try:
        assert echoes(ns, peer, 20) == 20
        heal = nodes.cut(peer)
        assert echoes(ns, peer, 20) == 0
        heal()
        heal()  # a heal counts once
        assert echoes(ns, peer, 20) == 20
        heal_loss = nodes.cut(peer, loss_percent=30)
        got = echoes(ns, peer, 100)
        assert 0 < got < 100  # each way 30 %: about half the round trips come back
        heal_loss()
        assert echoes(ns, peer, 20) == 20
    finally:
        nodes.close()
