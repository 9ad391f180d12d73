"""The incarnation border between nodes: a peer's proofs checked, and made this node's.

Each node's root supervisor is the authority for the incarnations of the components it
starts, with a fresh key per run of its own (mrss/messages/credentials.py): the
components of one node prove their incarnation to each other under that node's key.
Between nodes the bus proxies translate at the border (mrss.bus.mesh):

* each proxy sends its node's key to every peer in its `NodeBeat`, over the CurveZMQ
  link: encrypted, to the peer whose public key it pinned, and taken only from a
  connection authenticated as the node the beat names (the ZAP gate's user id);
* what a peer's connection carries is checked with that peer's key before local
  components see it: every envelope that claims an incarnation (inc > 0) must carry a
  credential the peer's key proves, and a `sup.start` proves its child's incarnation
  the same way. A proven claim is re-minted: the envelope (and the announcement) leave
  the border with this node's credential for the same (src, inc), so the local rule
  (mrss/bus/incarnations.py) checks one key, its own, whatever node a sender runs on;
* a claim the peer's key does not prove (or any claim before the peer's key is known)
  is refused at the border and counted, like any refusal, in this process's
  `refusal_counts` (the proxy's `Rejections` report); an announcement it does not prove
  passes without its credential, so the local rule refuses (and counts) it as unproven;
  a peer whose beats carry no key (an older release) is warned of once.

So a forged heartbeat with a huge `inc`, sent to any node's local bus, is refused on
every node; a recording of another run (another key on every node) proves nothing; and
a component restart on one node (a new incarnation, proven by its node's key) raises
the bar on all of them. Stale and replayed messages pass the border re-minted, as they
came: each receiver's own rule refuses them, and observers (`Stale.KEEP`) see them.

A node without a key (a bus nobody supervises: benchmarks, tests of the mesh alone)
believes every claim, as a keyless bus does: its border passes everything unchanged.
"""

from __future__ import annotations

import logging
from typing import Any

import msgpack

from mrss.bus.incarnations import ANNOUNCEMENT, Incarnations, Refusal
from mrss.errors import BusError
from mrss.messages import Envelope, IncarnationKey, SupEvent

log = logging.getLogger("mrss.bus.mesh")
# The envelope's `cred` as msgpack writes it: the key, then bin 8 of 16 bytes.
CRED_FIELD = b"\xa4cred\xc4\x10"
MAX_PROVEN = 4096  # (peer, src, inc, cred) proofs remembered; then start over


class Border:
    """What node `me` believes of its peers' incarnations (see the module docstring)."""

    def __init__(self, me: str, own: IncarnationKey | None) -> None:
        self.me = me
        self.own = own
        self._peers: dict[str, IncarnationKey] = {}
        self._counts: dict[str, Incarnations] = {}  # per peer: counted in refusal_counts
        # (peer, src, inc, its cred) -> our cred: each proof checked and minted once
        self._proven: dict[tuple[str, str, int, bytes], bytes] = {}
        self._keyless: set[str] = set()

    def learn(self, peer: str, key_hex: str) -> None:
        """Peer `peer` (authenticated as it) runs with the incarnation key `key_hex`."""
        if self.own is None:
            return
        if not key_hex:
            if peer not in self._keyless:  # once: a node of an older release
                self._keyless.add(peer)
                log.warning("node %s: node %s sends no incarnation key (an older release "
                            "of mrss?): what its components claim is refused here until "
                            "it runs this release too", self.me, peer)
            return
        try:
            key = IncarnationKey(bytes.fromhex(key_hex), f"node {peer}")
        except (ValueError, BusError):
            log.warning("node %s: node %s sent an incarnation key of the wrong shape; "
                        "its claims stay unproven", self.me, peer)
            return
        if self._peers.get(peer) != key:
            if peer in self._peers:
                log.info("node %s: node %s runs with a new incarnation key (its root "
                         "supervisor restarted)", self.me, peer)
            self._peers[peer] = key
            self._proven = {k: v for k, v in self._proven.items() if k[0] != peer}

    def knows(self, peer: str) -> bool:
        return peer in self._peers

    def cross(self, peer: str, env: Envelope, payload: bytes) -> bytes | None:
        """`payload` (decoded as `env`) as it may enter this node from `peer`: re-minted
        with this node's key, unchanged when nothing is claimed, or None when refused."""
        own = self.own
        if own is None:
            return payload
        announced = _announced(env)
        if env.inc <= 0 and announced is None:
            return payload  # no claim to prove
        key = self._peers.get(peer)
        if key is None:
            self._refuse(peer, env, f"inc {env.inc}, before node {peer}'s incarnation "
                                    "key was heard")
            return None
        ours = b""
        if env.inc > 0:
            ours = self._prove(peer, key, own, env)
            if not ours:
                self._refuse(peer, env, f"inc {env.inc}, {'a wrong' if env.cred else 'no'} "
                                        f"credential from node {peer}")
                return None
            if announced is None:  # the common case: swap the 16 bytes in place
                at = payload.rfind(CRED_FIELD + env.cred)
                if at >= 0:
                    start = at + len(CRED_FIELD)
                    return payload[:start] + ours + payload[start + len(ours):]
        message: dict[str, Any] = msgpack.unpackb(payload, raw=False)
        if env.inc > 0:
            message["cred"] = ours
        if announced is not None:
            child, inc, cred = announced
            detail = message["body"]["detail"]
            if _proves(key, child, inc, cred):
                detail["cred"] = own.credential(child, inc).hex()
            else:  # the local rule refuses it as unproven (and counts it)
                detail.pop("cred", None)
        return bytes(msgpack.packb(message, use_bin_type=True))

    def _prove(self, peer: str, key: IncarnationKey, own: IncarnationKey,
               env: Envelope) -> bytes:
        """Our credential for env's (src, inc) if `key` proves its own; else b""."""
        seen = (peer, env.src, env.inc, env.cred)
        ours = self._proven.get(seen)
        if ours is None:
            if not key.vouches(env.src, env.inc, env.cred):
                return b""
            if len(self._proven) >= MAX_PROVEN:
                self._proven.clear()
            ours = self._proven[seen] = own.credential(env.src, env.inc)
        return ours

    def _refuse(self, peer: str, env: Envelope, detail: str) -> None:
        counter = self._counts.get(peer)
        if counter is None:
            counter = self._counts[peer] = Incarnations(f"node {self.me}, from node {peer}")
        counter.refuse(env, Refusal.UNPROVEN, detail)

    @property
    def refused(self) -> int:
        """Refusals at this border since start."""
        return sum(c.dropped for c in self._counts.values())


def _announced(env: Envelope) -> tuple[str, int, str] | None:
    """(child, inc, cred hex) of a `sup.start` that claims an incarnation; else None."""
    body = env.body
    if not isinstance(body, SupEvent) or env.topic != ANNOUNCEMENT:
        return None
    inc, cred = body.detail.get("inc"), body.detail.get("cred", "")
    if not isinstance(inc, int) or isinstance(inc, bool):
        return None
    return body.child, inc, cred if isinstance(cred, str) else ""


def _proves(key: IncarnationKey, child: str, inc: int, cred: str) -> bool:
    try:
        return key.vouches(child, inc, bytes.fromhex(cred))
    except ValueError:
        return False
