"""Node membership: which peer nodes are up, from their heartbeats (`NodeBeat`).

Each node's bus proxy sends a beat to every peer every `interval` seconds and feeds the
beats it receives, with the node their CurveZMQ key authenticated, into a `Membership`.
A peer moves between states by one table (`TRANSITIONS`), each move with a cause:

| from \\ cause | heard | silent | clock_skew, duplicate, impostor |
|---|---|---|---|
| waiting (never heard) | up | down | refused |
| up | up | down | refused |
| down | up | down | refused |
| refused | up | down | refused |

* silent: no accepted beat for `interval * misses` seconds (from the start, for a node
  never heard);
* clock_skew: the beat's send time is more than `max_skew` seconds off our clock;
* duplicate: two processes beat as one node (an older instance still beats after a
  newer one appeared); refused until only one has been heard for a silence window;
* impostor: a node's key sent a beat naming another node.
A refused node's messages are dropped (`admits`); `down` and `refused` are both "lost"
for the rest of the system (`sup.node_down`), `up` again is `sup.node_up`. Pure: no
I/O, clocks injected (tests drive it by hand).
"""

from __future__ import annotations

import time
from collections.abc import Callable, Iterable
from dataclasses import dataclass, field
from enum import StrEnum

from mrss.messages import SupEventKind

NODE_DOWN = SupEventKind.NODE_DOWN  # SupEvent.event names
NODE_UP = SupEventKind.NODE_UP


class NodeState(StrEnum):
    WAITING = "waiting"  # not heard from yet
    UP = "up"
    DOWN = "down"
    REFUSED = "refused"

    @property
    def lost(self) -> bool:
        return self in (NodeState.DOWN, NodeState.REFUSED)


class NodeCause(StrEnum):
    HEARD = "heard"
    SILENT = "silent"
    CLOCK_SKEW = "clock_skew"
    DUPLICATE = "duplicate"
    IMPOSTOR = "impostor"


_REFUSALS = (NodeCause.CLOCK_SKEW, NodeCause.DUPLICATE, NodeCause.IMPOSTOR)
TRANSITIONS: dict[tuple[NodeState, NodeCause], NodeState] = {
    **{(s, NodeCause.HEARD): NodeState.UP for s in NodeState},
    **{(s, NodeCause.SILENT): NodeState.DOWN for s in NodeState},
    **{(s, c): NodeState.REFUSED for s in NodeState for c in _REFUSALS},
}


@dataclass(frozen=True)
class Transition:
    """A peer changed state: the event to publish (`NODE_DOWN`/`NODE_UP`) and why."""

    node: str
    before: NodeState
    after: NodeState
    cause: NodeCause
    reason: str

    @property
    def event(self) -> SupEventKind:
        return NODE_DOWN if self.after.lost else NODE_UP


@dataclass
class _Peer:
    name: str
    state: NodeState = NodeState.WAITING
    cause: NodeCause = NodeCause.SILENT
    reason: str = "not heard from yet"
    last: float = 0.0  # when an accepted beat was last heard (or the start)
    boots: dict[str, tuple[float, float]] = field(default_factory=dict)  # first, last heard


class Membership:
    """The peers of node `me` and their states (see the module docstring)."""

    def __init__(self, me: str, peers: Iterable[str], *, interval: float, misses: int,
                 max_skew: float, clock: Callable[[], float] = time.monotonic,
                 wall: Callable[[], float] = time.time) -> None:
        self.me = me
        self.window = interval * misses
        self.max_skew = max_skew
        self._clock = clock
        self._wall = wall
        now = clock()
        self._peers = {p: _Peer(p, last=now) for p in peers if p != me}

    def state(self, node: str) -> NodeState:
        return self._peers[node].state

    def states(self) -> dict[str, tuple[NodeState, str]]:
        return {p.name: (p.state, p.reason) for p in self._peers.values()}

    def lost(self) -> list[Transition]:
        """The peers lost now, as (unchanged) transitions: for level-triggered repeats."""
        return [Transition(p.name, p.state, p.state, p.cause, p.reason)
                for p in self._peers.values() if p.state.lost]

    def admits(self, node: str) -> bool:
        """Whether messages authenticated as `node` are let in."""
        peer = self._peers.get(node)
        return peer is not None and peer.state is not NodeState.REFUSED

    def beat(self, who: str, node: str, boot: str, sent: float) -> list[Transition]:
        """A beat arrived over a connection authenticated as `who`, naming `node`, from
        process `boot`, sent at wall time `sent`."""
        peer = self._peers.get(who)
        if peer is None:
            return []
        now = self._clock()
        if node != who:
            return self._move(peer, NodeCause.IMPOSTOR,
                              f"the key of node {who!r} sent a beat as node {node!r}")
        skew = sent - self._wall()
        if abs(skew) > self.max_skew:
            return self._move(peer, NodeCause.CLOCK_SKEW,
                              f"its clock is {abs(skew):.1f} s "
                              f"{'ahead of' if skew > 0 else 'behind'} ours (more than "
                              f"max_clock_skew {self.max_skew:g} s)")
        first, _ = peer.boots.get(boot, (now, now))
        peer.boots[boot] = (first, now)
        recent = {b: t for b, t in peer.boots.items() if now - t[1] <= self.window}
        peer.boots = recent
        newest = max(recent.values(), key=lambda t: t[0])[0]
        if len(recent) > 1 and first < newest:
            return self._move(peer, NodeCause.DUPLICATE,
                              f"two processes run as node {node!r} (boots "
                              f"{', '.join(sorted(recent))})")
        if peer.state is NodeState.REFUSED and peer.cause is NodeCause.DUPLICATE \
                and len(recent) > 1:
            return []  # still two of them
        peer.last = now
        if peer.state is NodeState.UP:
            return []
        return self._move(peer, NodeCause.HEARD, "heartbeats heard")

    def tick(self) -> list[Transition]:
        """Silence detection; call every interval or so."""
        now = self._clock()
        moved: list[Transition] = []
        for peer in self._peers.values():
            if peer.state is NodeState.REFUSED and peer.cause is NodeCause.DUPLICATE:
                alive = [b for b, t in peer.boots.items() if now - t[1] <= self.window]
                if len(alive) <= 1:
                    peer.boots = {b: peer.boots[b] for b in alive}
                    moved += self._move(peer, NodeCause.HEARD if alive else NodeCause.SILENT,
                                        "one process again" if alive else "silent")
                continue
            if peer.state in (NodeState.WAITING, NodeState.UP) and now - peer.last > self.window:
                heard = "since start" if peer.state is NodeState.WAITING else \
                    f"for {now - peer.last:.1f} s"
                moved += self._move(peer, NodeCause.SILENT, f"no heartbeat {heard}")
        return moved

    def _move(self, peer: _Peer, cause: NodeCause, reason: str) -> list[Transition]:
        before = peer.state
        after = TRANSITIONS[(before, cause)]
        if after is before and cause is peer.cause:
            return []
        peer.state, peer.cause, peer.reason = after, cause, reason
        return [Transition(peer.name, before, after, cause, reason)]
