"""A project's nodes on one host: each in a network namespace of its own, on one wire.

A campaign on a project with `[nodes]` runs every node (`mrss supervise PROJECT --node
NAME`) in a network namespace of its own, as if each were a host of its own: the
namespace `mrss-<tag>-<node>` has the node's configured address (`[nodes.NAME] address`,
an IPv4 address) on a veth whose other end is on a bridge in a hub namespace
(`mrss-<tag>-hub`), with a route to each peer's address over it. The nodes' bus proxies
talk over real TCP through that wire, CurveZMQ and all, so a packet filter on it acts on
their traffic: `node_partition` and `node_loss` are nftables rules (mrss.chaos.network
`NodeFilter`) in the namespace of the campaign's own node (the one with the RCL, whose
bus the recorder hears), on a peer's address; `node_delay` holds that traffic in relays
the campaign put in its path before the nodes started (`relay`, mrss.chaos.node_relays).

Unix sockets are not bound to a network namespace: the recorder hears the home node's
bus as on one host. TCP on 127.0.0.1 is the namespace's own: the campaign's thread
`enter`s the home node's namespace (setns(2) moves the calling thread only; the threads
it starts then are born there), so the operator and the robot links' relays reach the
home node's broker and simulators on its loopback; `leave` moves it back. It needs
root and `ip` (iproute2), and an IPv4 address per node; `why_no_netns` says what is
missing. `close` deletes the namespaces (and with them every veth end and the bridge).
"""

from __future__ import annotations

import ctypes
import ipaddress
import os
import shutil
import subprocess
import threading
import uuid

from mrss.chaos.network import Heal, NetworkError, NodeFilter, why_no_nft
from mrss.chaos.node_relays import NodeRelays, RelayError
from mrss.config.nodes import Node


def why_no_netns(nodes: dict[str, Node]) -> str:
    """Why the nodes cannot each get a namespace here ("" when they can)."""
    if os.geteuid() != 0:
        return "needs root (network namespaces)"
    if shutil.which("ip") is None:
        return "the ip command (package iproute2) is not installed"
    for node in nodes.values():
        try:
            ipaddress.IPv4Address(node.address)
        except ValueError:
            return f"node {node.name}: address {node.address!r} is not an IPv4 address"
    return ""


CLONE_NEWNET = 0x40000000
NETNS_DIR = "/run/netns"  # where `ip netns add` mounts a named namespace


def _setns(fd: int) -> None:
    libc = ctypes.CDLL(None, use_errno=True)
    if libc.setns(fd, CLONE_NEWNET) != 0:
        raise NetworkError(f"setns: {os.strerror(ctypes.get_errno())}")


def _ip(*args: str, ns: str = "") -> None:
    argv = ["ip", "-n", ns, *args] if ns else ["ip", *args]
    done = subprocess.run(argv, capture_output=True, text=True, timeout=10, check=False)
    if done.returncode != 0:
        raise NetworkError(f"{' '.join(argv)}: {done.stderr.strip()}")


class NodeNetwork:
    """Namespaces for a project's nodes, joined by a bridge; a packet filter in one."""

    def __init__(self, nodes: dict[str, Node], home: str, tag: str = "") -> None:
        self.nodes = dict(nodes)
        self.home = home
        self.tag = tag or uuid.uuid4().hex[:6]
        self.hub = f"mrss-{self.tag}-hub"
        self._made: list[str] = []
        self.filter: NodeFilter | None = None
        self.relays: NodeRelays | None = None
        self._back: int | None = None  # the entered thread's own namespace (an fd)

    def namespace(self, node: str) -> str:
        return f"mrss-{self.tag}-{node}"

    def prefix(self, node: str) -> tuple[str, ...]:
        """The argv prefix that runs a command on `node` (in its namespace)."""
        return ("ip", "netns", "exec", self.namespace(node))

    @property
    def peers(self) -> list[str]:
        """The nodes other than the campaign's own: the targets of the node faults."""
        return sorted(n for n in self.nodes if n != self.home)

    def up(self) -> NodeNetwork:
        why = why_no_netns(self.nodes)
        if why:
            raise NetworkError(why)
        try:
            self._add(self.hub)
            _ip("link", "add", "br0", "type", "bridge", ns=self.hub)
            _ip("link", "set", "br0", "up", ns=self.hub)
            for i, (name, node) in enumerate(sorted(self.nodes.items())):
                ns = self.namespace(name)
                self._add(ns)
                inner, outer = f"mc{self.tag}{i}", f"mh{self.tag}{i}"
                _ip("link", "add", inner, "netns", ns, "type", "veth", "peer", "name", outer,
                    "netns", self.hub)
                _ip("link", "set", outer, "master", "br0", ns=self.hub)
                _ip("link", "set", outer, "up", ns=self.hub)
                _ip("addr", "add", f"{node.address}/32", "dev", inner, ns=ns)
                _ip("link", "set", inner, "up", ns=ns)
                for peer, other in self.nodes.items():
                    if peer != name and other.address != node.address:
                        _ip("route", "add", f"{other.address}/32", "dev", inner, ns=ns)
        except BaseException:
            self.close()
            raise
        if not why_no_nft():
            self.filter = NodeFilter(prefix=self.prefix(self.home))
        return self

    def cut(self, peer: str, loss_percent: int = 100) -> Heal:
        """Drop (`loss_percent` % of) the packets between the home node and `peer`; the
        heal. NetworkError when that cannot be done."""
        if peer not in self.nodes or peer == self.home:
            raise NetworkError(f"{peer}: not a peer node of {self.home}")
        if self.filter is None:
            raise NetworkError(why_no_nft() or "the network is not up")
        return self.filter.cut(self.nodes[peer].address, loss_percent)

    def relay(self, seed: int = 0) -> NodeRelays:
        """Relays between the home node and each peer, for `delay` (call from a thread
        that has `enter`ed the home node, before the nodes start: a connection made
        earlier does not pass them)."""
        if self.filter is None:
            raise NetworkError(why_no_nft() or "the network is not up")
        peers = {p: self.nodes[p] for p in self.peers}
        try:
            self.relays = NodeRelays(self.nodes[self.home], peers, self.prefix(self.home),
                                     seed).start()
        except (RelayError, OSError) as exc:
            raise NetworkError(f"relays between the nodes: {exc}") from None
        return self.relays

    def delay(self, peer: str, seconds: float) -> Heal:
        """Hold the traffic between the home node and `peer` `seconds` s; the heal."""
        if self.relays is None:
            raise NetworkError("no relays between the nodes (the campaign started none)")
        try:
            return self.relays.delay(peer, seconds)
        except RelayError as exc:
            raise NetworkError(str(exc)) from None

    def enter(self, node: str) -> None:
        """Move the calling thread into `node`'s namespace (until `leave`)."""
        if self._back is not None:
            raise NetworkError("a thread is in a node's namespace already")
        back = os.open(f"/proc/self/task/{threading.get_native_id()}/ns/net", os.O_RDONLY)
        target = os.open(f"{NETNS_DIR}/{self.namespace(node)}", os.O_RDONLY)
        try:
            _setns(target)
        except NetworkError:
            os.close(back)
            raise
        finally:
            os.close(target)
        self._back = back

    def leave(self) -> None:
        """Move the thread that `enter`ed back to its own namespace."""
        if self._back is not None:
            try:
                _setns(self._back)
            finally:
                os.close(self._back)
                self._back = None

    def close(self) -> None:
        self.leave()
        if self.relays is not None:
            self.relays.close()
            self.relays = None
        if self.filter is not None:
            self.filter.close()
            self.filter = None
        for ns in reversed(self._made):  # deleting a namespace deletes its veth ends
            subprocess.run(["ip", "netns", "del", ns], capture_output=True, timeout=10,
                           check=False)
        self._made.clear()

    def _add(self, ns: str) -> None:
        _ip("netns", "add", ns)
        self._made.append(ns)
        _ip("link", "set", "lo", "up", ns=ns)
