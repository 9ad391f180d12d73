"""The direct proxy's loop: it introduces members to publishers and forwards no messages.

mrss/bus/direct.py states the rules; this is rules 2 and 5 on the proxy's side:

* Every subscription from the backend is passed on to the publishers, except `""`.
* A restarted proxy first lets its clients reconnect, which ZeroMQ does within
  `RECONNECT_IVL_MAX_MS`: only after `GRACE` seconds does it subscribe its marker, which
  introduces it to its publishers with every member it has by then (ZeroMQ replays a
  proxy's subscriptions in byte order, the marker last). A publisher that hears of it
  earlier holds what it publishes meanwhile (its first words). A *fresh* proxy (the
  first on its endpoints: no earlier one answered any member, so there is no member it
  could miss that was promised anything) subscribes its marker at once; a member that
  connects later is introduced as it comes, as on a proxy that forwards.
* A publisher says `HELLO` (its id and pid) on the marker, `JOINED` (its id, a membership
  topic) when a member has joined it (again for all its members on a new marker), `BYE`
  when it closes.
* A membership is answered (one frame, the membership topic, on the backend: only that
  member takes it) once every publisher the proxy knows has joined it, from `SETTLE`
  after the marker on (the publishers' hellos are in by then); a publisher that said bye
  or whose process is gone is not waited for; after `PATIENCE` the member is answered
  anyway (logged, with who did not join).
"""

from __future__ import annotations

import time
from dataclasses import dataclass, field

import msgpack
import zmq

from mrss.bus import sockets
from mrss.bus.direct import MARKER, MEMBER, PATIENCE, alive
from mrss.bus.wire import BYE, HELLO, JOINED

log = sockets.log

GRACE = sockets.RECONNECT_IVL_MAX_MS / 1000 + 0.1  # seconds before the marker
SETTLE = 0.1  # seconds after the marker before the first answer
_LOOK = 0.05  # seconds between looks (marker due, dead publishers, patience)


@dataclass
class _Member:
    joined: set[bytes] = field(default_factory=set)  # publishers it has joined
    deadline: float = field(default_factory=lambda: time.monotonic() + PATIENCE)


class Introducer:
    """The state of a direct proxy: its publishers, and the members not answered yet."""

    def __init__(self, frontend: sockets.Socket, backend: sockets.Socket, *,
                 fresh: bool = False) -> None:
        self.frontend = frontend
        self.backend = backend
        self.publishers: dict[bytes, int] = {}  # id -> pid
        self.waiting: dict[bytes, _Member] = {}  # membership topic -> not answered yet
        grace = 0.0 if fresh else GRACE  # a fresh proxy has no clients to wait for
        now = time.monotonic()
        self._marker_at: float | None = now + grace  # None once subscribed
        self._answer_from = now + grace + SETTLE

    @property
    def marker_due(self) -> float | None:
        """When the marker goes out (monotonic seconds); None once it has."""
        return self._marker_at

    @property
    def busy(self) -> bool:
        """Whether something is due without a message: the marker, or an answer."""
        return self._marker_at is not None or bool(self.waiting)

    def on_subscription(self, notice: bytes) -> None:
        if len(notice) < 2:
            return  # "" is not passed on: publishers would take it for a plain proxy
        self.frontend.send(notice)
        topic = notice[1:]
        if topic[:1] != MEMBER:
            return
        if notice[:1] == b"\x01":
            self.waiting[topic] = _Member()
            self._answer_if_joined(topic)
        else:
            self.waiting.pop(topic, None)

    def on_publisher(self, frames: list[bytes]) -> None:
        """A publisher's hello, join or bye; anything else is dropped."""
        try:
            if frames[0] == HELLO and len(frames) == 2:
                pub_id, pid = msgpack.unpackb(frames[1])
                if isinstance(pub_id, bytes) and isinstance(pid, int):
                    self.publishers[pub_id] = pid
            elif frames[0] == JOINED and len(frames) == 3:
                member = self.waiting.get(frames[2])
                if member is not None:
                    member.joined.add(frames[1])
                    self._answer_if_joined(frames[2])
            elif frames[0] == BYE and len(frames) == 2:
                self.publishers.pop(frames[1], None)
                self._answer_all()
        except (ValueError, TypeError, msgpack.ExtraData, msgpack.FormatError,
                msgpack.StackError):
            log.warning("bus proxy: dropped a malformed note from a publisher")

    def look(self) -> None:
        """Subscribe the marker when due; drop publishers whose process is gone; answer
        members whose publishers have all joined, or whose patience is out."""
        now = time.monotonic()
        if self._marker_at is not None and now >= self._marker_at:
            self._marker_at = None
            self.frontend.send(b"\x01" + MARKER)
        if not self.waiting or now < self._answer_from:
            return
        for pub_id, pid in list(self.publishers.items()):
            if not alive(pid):
                del self.publishers[pub_id]
        for topic, member in list(self.waiting.items()):
            if not self._answer_if_joined(topic) and now >= member.deadline:
                missing = sorted(pid for p, pid in self.publishers.items()
                                 if p not in member.joined)
                log.warning("bus proxy: publisher(s) of pid %s did not join a member within "
                            "%.1f s; answering it anyway", missing, PATIENCE)
                self._answer(topic)

    def _answer_all(self) -> None:
        for topic in list(self.waiting):
            self._answer_if_joined(topic)

    def _answer_if_joined(self, topic: bytes) -> bool:
        member = self.waiting.get(topic)
        if member is None or time.monotonic() < self._answer_from or \
                not self.publishers.keys() <= member.joined:
            return False
        self._answer(topic)
        return True

    def _answer(self, topic: bytes) -> None:
        del self.waiting[topic]
        self.backend.send(topic)


def introduce(frontend: sockets.Socket, backend: sockets.Socket, control: sockets.Socket,
              fresh: bool = False) -> None:
    """Run the direct proxy until a message on `control` (its stop); `fresh`: the first
    proxy on its endpoints (introduce at once)."""
    state = Introducer(frontend, backend, fresh=fresh)
    state.look()  # a fresh proxy's marker: now, not after the first poll
    poller = zmq.Poller()
    for sock in (frontend, backend, control):
        poller.register(sock, zmq.POLLIN)
    try:
        while True:
            ready = dict(poller.poll(int(_LOOK * 1000) if state.busy else None))
            if control in ready:
                return
            if backend in ready:
                while backend.poll(0):
                    state.on_subscription(backend.recv_multipart()[0])
            if frontend in ready:
                while frontend.poll(0):
                    state.on_publisher(frontend.recv_multipart())
            state.look()
    except zmq.ZMQError as exc:
        if exc.errno != zmq.ETERM:
            log.error("bus proxy stopped: %s", exc)
