"""Relays between nodes: the nodes' CurveZMQ traffic through userspace, for `node_delay`.

The kernel's netem (`tc qdisc ... netem delay`) would delay packets on the wire between
the nodes' namespaces, but it is not in every kernel (not in the one MRSS's CI runs on:
"Specified qdisc kind is unknown"). So a campaign with `node_delay` in its plan puts a
`TcpRelay` (mrss.chaos.relay) in each direction between the home node and each peer,
before the nodes start, and nftables NAT rules in the home node's namespace (table
`ip mrss_chaos_relay`) bring the traffic to them:

    home's proxy -> peer's inbox    output: `ip daddr PEER tcp dport PORT redirect` to
                                    the outbound relay on 127.0.0.1, whose own
                                    connection to the peer is marked (SO_MARK) and so
                                    passes the rule
    peer's proxy -> home's inbox    prerouting: `ip saddr PEER ip daddr HOME tcp dport
                                    PORT redirect` to the inbound relay on HOME's
                                    address, which connects to the inbox on it

Both relays of a peer share one `Impairments`: `delay(peer, s)` holds every chunk of
bytes either way `s` seconds until its heal. Without a fault the relays pass bytes at
once. A relay reads a chunk, holds it, sends it, then reads the next, so a chunk that
arrives while another is held waits for it too: a chunk is held between `s` and 2 `s`
(the jitter of a queue). The packet filter's partitions and losses (`NodeFilter`) still
act on the relayed traffic: NAT runs before the filter, which sees the relays' own
connections to and from the peer's address.

The relays' sockets are made in the namespace of the thread that creates them: build
and start a `NodeRelays` on a thread that has entered the home node's namespace.
"""

from __future__ import annotations

import subprocess
from collections.abc import Callable

from mrss.chaos.relay import Impairment, Impairments, TcpRelay
from mrss.config.nodes import Node
from mrss.errors import MrssError

Heal = Callable[[], None]
NAT_TABLE = "mrss_chaos_relay"
MARK = 0x6D72  # "mr": the relays' own connections to a peer


class RelayError(MrssError):
    """The relays between nodes cannot be set up here."""


class NodeRelays:
    """A pair of delaying relays between the home node and each peer (module docstring)."""

    def __init__(self, home: Node, peers: dict[str, Node], prefix: tuple[str, ...],
                 seed: int = 0) -> None:
        self.home = home
        self.peers = dict(peers)
        self.prefix = prefix  # runs a command in the home node's namespace
        self.impairments: dict[str, Impairments] = {}
        self.relays: dict[str, tuple[TcpRelay, TcpRelay]] = {}
        self._made = False
        for n, (name, peer) in enumerate(sorted(self.peers.items())):
            impairments = Impairments(seed=seed * 1000 + 500 + n)
            out = TcpRelay(_fixed(peer.address, peer.port), impairments, mark=MARK)
            inbound = TcpRelay(_fixed(home.address, home.port), impairments,
                               host=home.address)
            self.impairments[name], self.relays[name] = impairments, (out, inbound)

    def start(self) -> NodeRelays:
        """Start the relays and put the redirects in place."""
        try:
            self._nft(f"add table ip {NAT_TABLE}")
            self._made = True
            for hook in ("output", "prerouting"):
                self._nft(f"add chain ip {NAT_TABLE} {hook} "
                          f"{{ type nat hook {hook} priority -100 ; }}")
            for name, (out, inbound) in self.relays.items():
                peer = self.peers[name]
                out.start()
                inbound.start()
                self._nft(f"add rule ip {NAT_TABLE} output ip daddr {peer.address} tcp dport "
                          f"{peer.port} meta mark != {MARK} redirect to :{out.address[1]}")
                self._nft(f"add rule ip {NAT_TABLE} prerouting ip saddr {peer.address} ip "
                          f"daddr {self.home.address} tcp dport {self.home.port} redirect "
                          f"to :{inbound.address[1]}")
        except BaseException:
            self.close()
            raise
        return self

    def delay(self, peer: str, seconds: float) -> Heal:
        """Hold the bytes between the home node and `peer` `seconds` s; the heal."""
        if peer not in self.impairments:
            raise RelayError(f"{peer}: no relay between it and {self.home.name}")
        return self.impairments[peer].add(Impairment.DELAY, seconds)

    def counts(self) -> dict[str, dict[str, int]]:
        return {name: {f"{way}_{k}": v for way, relay in zip(("out", "in"), pair, strict=True)
                       for k, v in relay.counts.items()}
                for name, pair in self.relays.items()}

    def close(self) -> None:
        if self._made:
            self._nft(f"delete table ip {NAT_TABLE}", check=False)
            self._made = False
        for pair in self.relays.values():
            for relay in pair:
                relay.close()

    def _nft(self, command: str, check: bool = True) -> None:
        done = subprocess.run([*self.prefix, "nft", *command.split()], capture_output=True,
                              text=True, timeout=10, check=False)
        if check and done.returncode != 0:
            raise RelayError(f"nft {command}: {done.stderr.strip()}")


def _fixed(host: str, port: int) -> Callable[[], tuple[str, int]]:
    return lambda: (host, port)
