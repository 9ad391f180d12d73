"""The incarnation border between nodes: a peer's proofs checked, and made this node's.

Each node's root supervisor is the authority for the incarnations of the components it
starts, with a fresh key per run of its own (mrss/messages/credentials.py): the
components of one node prove their incarnation to each other under that node's key.
Between nodes the bus proxies translate at the border (mrss.bus.mesh):

* each proxy sends its node's key and the run it is for (`run`, mrss/messages/
  credentials.py) to every peer in its `NodeBeat`, over the CurveZMQ link: encrypted,
  to the peer whose public key it pinned, and taken only from a connection
  authenticated as the node the beat names (the ZAP gate's user id);
* what a peer's connection carries is checked with that peer's key before local
  components see it: every envelope that claims an incarnation (inc > 0) must carry a
  credential the peer's key proves, and a `sup.start` proves its child's incarnation
  the same way. A proven claim is translated and re-minted: incarnation i of the peer's
  run r enters as `across_runs(r, i)`, with this node's credential for that number (the
  envelope, and the announcement), so the local rule (mrss/bus/incarnations.py) checks
  one key, its own, whatever node a sender runs on, and a peer's new run (its root
  restarted: a new key, a higher run, incarnations from 1 again) ranks above its last
  one: nothing a local component learnt of the last run silences the new one. The
  translation is a function of what the peer's beat says, nothing this proxy keeps,
  so a restart of this proxy changes no number;
* a claim the peer's key does not prove (or any claim before the peer's key is known:
  a recording of another run, the last run's messages after a restart of its root)
  is refused at the border and counted, like any refusal, in this process's
  `refusal_counts` (the proxy's `Rejections` report); an announcement it does not prove
  passes without its credential, so the local rule refuses (and counts) it as unproven;
  a peer whose beats carry no key (an older release) is warned of once, and so is a
  peer whose new run has a lower number than its last (its clock went back and its run
  directory was not kept: its components stay refused as dead here until they restart).

So a forged heartbeat with a huge `inc`, sent to any node's local bus, is refused on
every node; a recording of another run (another key on every node) proves nothing; a
component restart on one node (a new incarnation, proven by its node's key) raises the
bar on all of them, and so does a restart of a node's root. Stale and replayed messages
pass the border re-minted, as they came: each receiver's own rule refuses them, and
observers (`Stale.KEEP`) see them.

A node without a key (a bus nobody supervises: benchmarks, tests of the mesh alone)
believes every claim, as a keyless bus does: its border passes everything unchanged.
"""

from __future__ import annotations

import logging
from dataclasses import dataclass
from typing import Any

import msgpack

from mrss.bus.incarnations import ANNOUNCEMENT, Incarnations, Refusal
from mrss.errors import BusError
from mrss.messages import RUN_SPAN, Envelope, IncarnationKey, SupEvent, across_runs

log = logging.getLogger("mrss.bus.mesh")
# The envelope's `cred` as msgpack writes it: the key, then bin 8 of 16 bytes.
CRED_FIELD = b"\xa4cred\xc4\x10"
MAX_PROVEN = 4096  # (peer, src, inc, cred) proofs remembered; then start over


@dataclass(frozen=True)
class Minted:
    """A peer's proven (src, inc) as it enters: the bytes of `src, inc` in the envelope
    as the peer sent them and as they enter, and this node's credential."""

    came: bytes
    enters: bytes
    inc: int
    cred: bytes


class Border:
    """What node `me` believes of its peers' incarnations (see the module docstring)."""

    def __init__(self, me: str, own: IncarnationKey | None) -> None:
        self.me = me
        self.own = own
        self._peers: dict[str, IncarnationKey] = {}
        self._counts: dict[str, Incarnations] = {}  # per peer: counted in refusal_counts
        # (peer, src, inc, its cred) -> as it enters: each proof checked and minted once
        self._proven: dict[tuple[str, str, int, bytes], Minted] = {}
        self._keyless: set[str] = set()

    def learn(self, peer: str, key_hex: str, run: int = 0) -> None:
        """Peer `peer` (authenticated as it) runs with the incarnation key `key_hex`, for
        its run `run`."""
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
            key = IncarnationKey(bytes.fromhex(key_hex), f"node {peer}", run)
        except (ValueError, BusError):
            log.warning("node %s: node %s sent an incarnation key of the wrong shape; "
                        "its claims stay unproven", self.me, peer)
            return
        last = self._peers.get(peer)
        if last != key:
            if last is not None and key.run <= last.run and key.run:
                log.warning("node %s: node %s runs again (a new incarnation key) with run "
                            "%d, not above its last run %d (its clock went back, and its "
                            "run directory was not kept?): what components here learnt "
                            "of its last run refuses its components as dead until they "
                            "restart", self.me, peer, key.run, last.run)
            elif last is not None:
                log.info("node %s: node %s runs again (its root supervisor restarted): "
                         "run %d, after run %d", self.me, peer, key.run, last.run)
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
        minted: Minted | None = None
        if env.inc > 0:
            minted = self._prove(peer, key, own, env)
            if minted is None:
                self._refuse(peer, env, _unproven(env, peer))
                return None
            if announced is None:  # the common case: swap (src, inc) and the 16 bytes
                crossed = _swapped(payload, env.cred, minted)
                if crossed is not None:
                    return crossed
        message: dict[str, Any] = msgpack.unpackb(payload, raw=False)
        if minted is not None:
            message["inc"], message["cred"] = minted.inc, minted.cred
        if announced is not None:
            child, inc, cred = announced
            detail = message["body"]["detail"]
            if 0 < inc < RUN_SPAN and _proves(key, child, inc, cred):
                detail["inc"] = across_runs(key.run, inc)
                detail["cred"] = own.credential(child, detail["inc"]).hex()
            else:  # the local rule refuses it as unproven (and counts it)
                detail.pop("cred", None)
        return bytes(msgpack.packb(message, use_bin_type=True))

    def _prove(self, peer: str, key: IncarnationKey, own: IncarnationKey,
               env: Envelope) -> Minted | None:
        """env's (src, inc) as it enters, if `key` proves it; else None."""
        seen = (peer, env.src, env.inc, env.cred)
        minted = self._proven.get(seen)
        if minted is None:
            if env.inc >= RUN_SPAN or not key.vouches(env.src, env.inc, env.cred):
                return None
            if len(self._proven) >= MAX_PROVEN:
                self._proven.clear()
            inc = across_runs(key.run, env.inc)
            minted = self._proven[seen] = Minted(
                _src_inc(env.src, env.inc), _src_inc(env.src, inc), inc,
                own.credential(env.src, inc))
        return minted

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


def _unproven(env: Envelope, peer: str) -> str:
    if env.inc >= RUN_SPAN:
        return f"inc {env.inc}, more than one run of node {peer} numbers"
    return f"inc {env.inc}, {'a wrong' if env.cred else 'no'} credential from node {peer}"


def _src_inc(src: str, inc: int) -> bytes:
    """`src` and `inc` as the envelope's encoder writes them, one after the other."""
    return b"\xa3src" + bytes(msgpack.packb(src)) + b"\xa3inc" + bytes(msgpack.packb(inc))


def _swapped(payload: bytes, cred: bytes, minted: Minted) -> bytes | None:
    """`payload` with its (src, inc) and credential as they enter, without decoding it
    again; None if it is not laid out as our encoder writes it (then it is re-packed)."""
    at = payload.find(minted.came)
    end = payload.rfind(CRED_FIELD + cred)
    if at < 0 or end < at + len(minted.came):
        return None
    end += len(CRED_FIELD)
    return b"".join((payload[:at], minted.enters, payload[at + len(minted.came):end],
                     minted.cred, payload[end + len(cred):]))
