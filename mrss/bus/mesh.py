"""The bus proxy of one node of several: the local proxy, plus CurveZMQ links to the peers.

On a single host the proxy is `mrss.bus.forwarder` (libzmq's own proxy loop). A node of
a multi-node project (`[nodes]`, mrss.config.nodes) runs this instead, one thread polling:

* frontend (XSUB, local publishers) -> backend (XPUB, local subscribers) and every
  peer's inbox; backend subscriptions -> frontend, as the plain proxy does;
* inbox (SUB, bound on the node's tcp address, CURVE server): what the peers publish
  locally -> backend. Never forwarded on, so a full mesh has no loops. Each peer is a
  PUB of ours connected to its inbox (CURVE client, the peer's public key pinned);
* the ZAP gate (mrss.bus.curve): only the project's node keys get in;
* every `interval`: a `NodeBeat` to each peer, and `Membership.tick()`; a peer lost
  or back is published locally as `sup.node_down` / `sup.node_up` (src `node.<me>`,
  child the peer, `detail.components` its components), and repeated every silence
  window while it lasts (level-triggered, for components that started later).

Everything a peer sends is checked before local components see it: the frames' shape,
each envelope (`mrss.messages.decode`), the sender's state (a refused node's messages
are dropped), and every incarnation it claims, at the border (mrss.bus.border: proven
by the peer's incarnation key, which its beats carry with its run, and translated and
re-minted with this node's);
failures are logged (rate-limited) and counted, never raised.
Handshake failures on the inbox (garbage, a wrong mechanism) are logged from the
socket monitor.
"""

from __future__ import annotations

import logging
import threading
import time
import uuid
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import zmq
from zmq.utils.monitor import recv_monitor_message

from mrss.bus import sockets
from mrss.bus.border import Border
from mrss.bus.curve import DOMAIN, NodeKeys, ZapGate, load_keys, load_public
from mrss.bus.endpoints import BusEndpoints
from mrss.bus.forwarder import bind_endpoint, clear_stale_socket
from mrss.bus.wire import RELIABLE_PREFIX, WELCOME, is_ack, message_frames, unpack_ack
from mrss.errors import BusError, ConfigError, DecodeError
from mrss.messages import NodeBeat, SupEvent, decode, encode
from mrss.supervision.nodes import Membership, Transition

log = logging.getLogger("mrss.bus.mesh")

BEAT_TOPIC = b"node.beat."
# ZMTP heartbeats on the tcp links: a cut cable is noticed (and the link re-dialled) in
# about this long, instead of when TCP gives up.
ZMTP_HEARTBEAT_MS = 500
ZMTP_TIMEOUT_MS = 1500
_HANDSHAKE_EVENTS: dict[zmq.Event, str] = {
    zmq.EVENT_HANDSHAKE_FAILED_NO_DETAIL: "handshake failed",
    zmq.EVENT_HANDSHAKE_FAILED_PROTOCOL: "not the ZeroMQ protocol (garbage?)",
    zmq.EVENT_HANDSHAKE_FAILED_AUTH: "authentication refused",
}


@dataclass(frozen=True)
class MeshSettings:
    """What one node's proxy needs to know about the mesh (from `mrss.config.nodes.NodePlan`)."""

    node: str
    inbox: str  # tcp://bind:port of this node
    peers: dict[str, str]  # node -> its inbox endpoint
    keys_dir: str
    components: dict[str, list[str]]  # node -> its component ids
    interval: float = 0.5
    misses: int = 4
    max_skew: float = 5.0

    def to_dict(self) -> dict[str, Any]:
        return {"node": self.node, "inbox": self.inbox, "peers": dict(self.peers),
                "keys_dir": self.keys_dir, "components": dict(self.components),
                "interval": self.interval, "misses": self.misses, "max_skew": self.max_skew}

    @classmethod
    def from_dict(cls, data: Any) -> MeshSettings:
        try:
            return cls(str(data["node"]), str(data["inbox"]), dict(data["peers"]),
                       str(data["keys_dir"]), dict(data["components"]),
                       float(data["interval"]), int(data["misses"]), float(data["max_skew"]))
        except (KeyError, TypeError, ValueError) as exc:
            raise ConfigError(f"bad mesh settings: {exc!r}", key="mesh") from None


class MeshProxy:
    """One node's proxy (see the module docstring); `run()` blocks until `stop` is set."""

    def __init__(self, endpoints: BusEndpoints, settings: MeshSettings, *,
                 hwm: int = sockets.DEFAULT_HWM, wall: Callable[[], float] = time.time) -> None:
        self.endpoints = endpoints
        self.settings = settings
        self.hwm = hwm
        self.dropped = 0
        self.boot = uuid.uuid4().hex[:12]
        keys_dir = Path(settings.keys_dir)
        self.keys: NodeKeys = load_keys(keys_dir, settings.node)
        self.peer_keys = {p: load_public(keys_dir, p) for p in settings.peers}
        self.membership = Membership(settings.node, settings.peers, interval=settings.interval,
                                     misses=settings.misses, max_skew=settings.max_skew,
                                     wall=wall)
        self._wall = wall
        self._drops = sockets.DropLog(f"node {settings.node}: from a peer")
        self._src = f"node.{settings.node}"
        self._refusals: dict[tuple[str, str], int] = {}
        # this node's incarnation key (its root supervisor's, through the bus endpoints)
        self.border = Border(settings.node, endpoints.authority())
        self._key_hex = self.border.own.export() if self.border.own is not None else ""
        self._own_run = self.border.own.run if self.border.own is not None else 0

    def run(self, stop: threading.Event, ready: Callable[[], None] | None = None) -> None:
        ctx: sockets.Context = zmq.Context()  # own context: the ZAP gate covers only it
        made: list[sockets.Socket] = []

        def sock(kind: int) -> sockets.Socket:
            s = ctx.socket(kind)
            s.setsockopt(zmq.LINGER, 0)
            made.append(s)
            return s

        gate = ZapGate(ctx, {key: node for node, key in self.peer_keys.items()})
        bound: list[str] = []
        try:
            for path in self.endpoints.ipc_paths():
                clear_stale_socket(path)
            frontend, backend = sock(zmq.XSUB), sock(zmq.XPUB)
            frontend.setsockopt(zmq.RCVHWM, self.hwm)
            backend.setsockopt(zmq.SNDHWM, self.hwm)
            backend.setsockopt(zmq.XPUB_WELCOME_MSG, WELCOME)
            for s, ep in ((frontend, self.endpoints.frontend),
                          (backend, self.endpoints.backend)):
                bind_endpoint(s, ep)
                bound.append(ep)
            frontend.send(b"\x01")
            inbox = sock(zmq.SUB)
            self._curve(inbox)
            inbox.setsockopt(zmq.CURVE_SERVER, 1)
            inbox.setsockopt(zmq.ZAP_DOMAIN, DOMAIN)
            inbox.setsockopt(zmq.RCVHWM, self.hwm)
            inbox.setsockopt(zmq.SUBSCRIBE, b"")
            monitor = inbox.get_monitor_socket(
                zmq.EVENT_HANDSHAKE_FAILED_NO_DETAIL | zmq.EVENT_HANDSHAKE_FAILED_PROTOCOL
                | zmq.EVENT_HANDSHAKE_FAILED_AUTH)
            monitor.setsockopt(zmq.LINGER, 0)
            made.append(monitor)
            try:
                inbox.bind(self.settings.inbox)
            except zmq.ZMQError as exc:
                raise BusError(f"node {self.settings.node}: cannot bind its inbox "
                               f"{self.settings.inbox}: {exc} (is this node already "
                               "running here?)") from exc
            outs: dict[str, sockets.Socket] = {}
            for peer, endpoint in self.settings.peers.items():
                out = sock(zmq.PUB)
                self._curve(out)
                out.setsockopt(zmq.CURVE_SERVERKEY, self.peer_keys[peer])
                out.setsockopt(zmq.SNDHWM, self.hwm)
                out.setsockopt(zmq.RECONNECT_IVL, sockets.RECONNECT_IVL_MS)
                out.setsockopt(zmq.RECONNECT_IVL_MAX, sockets.RECONNECT_IVL_MAX_MS)
                out.connect(endpoint)
                outs[peer] = out
            log.info("node %s: bus proxy %s, %s; inbox %s (CURVE); peers %s",
                     self.settings.node, self.endpoints.frontend, self.endpoints.backend,
                     self.settings.inbox, ", ".join(f"{p} at {e}" for p, e in
                                                    self.settings.peers.items()))
            if ready is not None:
                ready()
            self._loop(stop, frontend, backend, inbox, monitor, gate, outs)
        finally:
            gate.close()
            for s in made:
                s.close(0)
            ctx.term()
            for path in BusEndpoints.paths_of(bound):
                path.unlink(missing_ok=True)

    def _curve(self, s: sockets.Socket) -> None:
        s.setsockopt(zmq.CURVE_PUBLICKEY, self.keys.public)
        s.setsockopt(zmq.CURVE_SECRETKEY, self.keys.secret)
        s.setsockopt(zmq.HEARTBEAT_IVL, ZMTP_HEARTBEAT_MS)
        s.setsockopt(zmq.HEARTBEAT_TIMEOUT, ZMTP_TIMEOUT_MS)

    def _loop(self, stop: threading.Event, frontend: sockets.Socket, backend: sockets.Socket,
              inbox: sockets.Socket, monitor: sockets.Socket, gate: ZapGate,
              outs: dict[str, sockets.Socket]) -> None:
        poller = zmq.Poller()
        for s in (frontend, backend, inbox, monitor, gate.socket):
            poller.register(s, zmq.POLLIN)
        interval = self.settings.interval
        next_beat = 0.0
        next_repeat = time.monotonic() + self.membership.window
        timeout_ms = max(10, int(interval * 250))
        while not stop.is_set():
            for s, _ in poller.poll(timeout_ms):
                if s is frontend:
                    frames = frontend.recv_multipart()
                    backend.send_multipart(frames)
                    for out in outs.values():
                        _send(out, frames)
                elif s is backend:
                    frontend.send_multipart(backend.recv_multipart())
                elif s is inbox:
                    self._from_peer(inbox.recv_multipart(copy=False), backend)
                elif s is gate.socket:
                    gate.handle()
                elif s is monitor:
                    self._monitor(monitor)
            now = time.monotonic()
            if now >= next_beat:
                next_beat = now + interval
                self._beat(outs)
                self._publish(backend, self.membership.tick())
            if now >= next_repeat:  # level-triggered: who is still lost
                next_repeat = now + self.membership.window
                self._publish(backend, self.membership.lost(), repeat=True)

    def _beat(self, outs: dict[str, sockets.Socket]) -> None:
        body = NodeBeat(node=self.settings.node, boot=self.boot,
                        components=list(self.settings.components.get(self.settings.node, [])),
                        key=self._key_hex, run=self._own_run)
        frames = list(encode(body, src=self._src))
        for out in outs.values():
            _send(out, frames)

    def _from_peer(self, frames: list[zmq.Frame], backend: sockets.Socket) -> None:
        try:
            who = str(frames[0].get("User-Id")) if frames else ""
        except zmq.ZMQError:  # no ZAP user: not a node
            who = ""
        raw = [f.bytes for f in frames]
        try:
            if raw and raw[0].startswith(BEAT_TOPIC):  # beats even from a refused node:
                env = decode(raw[0], raw[1]) if len(raw) == 2 else None  # it may recover
                if env is None or not isinstance(env.body, NodeBeat):
                    raise DecodeError("a node beat of the wrong shape", topic="node.beat")
                b = env.body
                self._publish(backend, self.membership.beat(who, b.node, b.boot, env.ts))
                if who == b.node and self.membership.admits(who):
                    self.border.learn(who, b.key, b.run)
                return
            if not self.membership.admits(who):
                self.dropped += 1
                return
            if raw and raw[0].startswith(b"node."):
                raise DecodeError("node.* topics are the proxies' own", topic="node.")
            if len(raw) == 2 and is_ack(raw[0]):
                unpack_ack(raw[1])
            else:
                raw = self._cross(who, raw)
                if not raw:
                    self.dropped += 1
                    return
        except DecodeError as exc:
            self.dropped += 1
            self._drops.drop(DecodeError(f"node {who}: {exc.reason}", topic=exc.topic))
            return
        backend.send_multipart(raw)

    def _cross(self, who: str, raw: list[bytes]) -> list[bytes]:
        """The frames of a peer's message as they may enter: every envelope decoded and
        through the border (re-minted); a batch loses the envelopes it refuses; [] when
        nothing is left. DecodeError for a malformed one."""
        pairs = message_frames(raw)
        if not pairs:
            return raw
        crossed = [self.border.cross(who, decode(topic, payload), payload)
                   for topic, payload in pairs]
        if self.border.own is None:
            return raw
        if len(raw) == 4 and raw[0].startswith(RELIABLE_PREFIX):  # [rel, topic, env, header]
            return [raw[0], raw[1], crossed[0], raw[3]] if crossed[0] is not None else []
        kept = [p for p in crossed if p is not None]
        return [raw[0], *kept] if kept else []

    def _publish(self, backend: sockets.Socket, moves: list[Transition], *,
                 repeat: bool = False) -> None:
        for move in moves:
            if not repeat:
                level = logging.WARNING if move.after.lost else logging.INFO
                log.log(level, "node %s: peer node %s is %s (%s: %s)", self.settings.node,
                        move.node, move.after.value, move.cause.value, move.reason)
            event = SupEvent(event=move.event, child=move.node, supervisor=self._src,
                             reason=f"node {move.node} {move.after.value}: {move.reason}",
                             node=self.settings.node,
                             detail={"state": move.after.value, "cause": move.cause.value,
                                     "components": list(self.settings.components.get(
                                         move.node, [])), "repeat": repeat})
            backend.send_multipart(list(encode(event, src=self._src)))

    def _monitor(self, monitor: sockets.Socket) -> None:
        try:
            event = recv_monitor_message(monitor)
        except zmq.ZMQError:
            return
        what = _HANDSHAKE_EVENTS.get(zmq.Event(int(event["event"])))
        if not what:
            return
        self.dropped += 1
        key = (what, str(event.get("endpoint", b""), "utf-8", "replace"))
        seen = self._refusals.get(key, 0) + 1
        if len(self._refusals) >= 1024:
            self._refusals.clear()
        self._refusals[key] = seen
        if seen == 1 or seen % 100 == 0:  # a peer re-dials every 0.5 s: not every time
            log.warning("node %s: refused a connection on its inbox: %s (%d time(s))",
                        self.settings.node, what, seen)


def _send(out: sockets.Socket, frames: list[Any]) -> None:
    try:
        out.send_multipart(frames, flags=zmq.NOBLOCK)
    except zmq.Again:
        pass  # a PUB does not block; kept for safety


class MeshThread:
    """A MeshProxy on a background thread (the bus component, tests)."""

    def __init__(self, endpoints: BusEndpoints, settings: MeshSettings, **kwargs: Any) -> None:
        self.proxy = MeshProxy(endpoints, settings, **kwargs)
        self._stop = threading.Event()
        self._ready = threading.Event()
        self._error: BaseException | None = None
        self._thread = threading.Thread(target=self._run, name="mrss-bus-mesh", daemon=True)

    def _run(self) -> None:
        try:
            self.proxy.run(self._stop, self._ready.set)
        except BaseException as exc:
            self._error = exc
            log.error("node proxy stopped: %s", exc)
            self._ready.set()

    def start(self, timeout: float = 10.0) -> MeshThread:
        self._thread.start()
        if not self._ready.wait(timeout):
            raise BusError(f"node proxy did not start within {timeout}s")
        if self._error is not None:
            raise self._error
        return self

    def alive(self) -> bool:
        return self._thread.is_alive()

    def stop(self) -> None:
        self._stop.set()
        self._thread.join(timeout=10)
