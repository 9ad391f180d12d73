"""The direct proxy's loop: it introduces members to publishers and forwards no messages.

mrss/bus/direct.py states the rules; this is rules 2 and 5 on the proxy's side:

* Every subscription from the backend is passed on to the publishers, except `""`.
* A publisher says `HELLO` (its id and pid) when it sees the proxy's marker, `JOINED`
  (its id, a membership topic) when a member has joined it, `BYE` when it closes.
* A new membership is answered (one frame, the membership topic, on the backend: only
  that member takes it) once every publisher known when it came has joined it, or has
  gone (said bye, or its process is gone), or after `PATIENCE` (logged, with who).
* A (re)started proxy knows its publishers only once they have reconnected and said
  hello, which ZeroMQ does within `RECONNECT_IVL_MAX_MS`: it answers no member in its
  first `GRACE` seconds.
"""

from __future__ import annotations

import time
from dataclasses import dataclass, field

import msgpack
import zmq

from mrss.bus import sockets
from mrss.bus.direct import MEMBER, PATIENCE, alive
from mrss.bus.wire import BYE, HELLO, JOINED

log = sockets.log

_LOOK = 50  # ms between looks at waiting members (dead publishers, patience)
GRACE = sockets.RECONNECT_IVL_MAX_MS / 1000 + 0.1


@dataclass
class _Waiting:
    publishers: set[bytes]
    deadline: float = field(default_factory=lambda: time.monotonic() + PATIENCE)


class Introducer:
    """The state of a direct proxy: its publishers, and the members not answered yet."""

    def __init__(self, frontend: sockets.Socket, backend: sockets.Socket) -> None:
        self.frontend = frontend
        self.backend = backend
        self.publishers: dict[bytes, int] = {}  # id -> pid
        self.waiting: dict[bytes, _Waiting] = {}  # membership topic -> who must join it
        self._known_from = time.monotonic() + GRACE  # every publisher said hello by then

    def on_subscription(self, notice: bytes) -> None:
        if len(notice) < 2:
            return  # "" is not passed on: publishers would take it for a plain proxy
        self.frontend.send(notice)
        topic = notice[1:]
        if topic[:1] != MEMBER:
            return
        if notice[:1] == b"\x01":
            self.waiting[topic] = _Waiting(set(self.publishers))
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
                waiting = self.waiting.get(frames[2])
                if waiting is not None:
                    waiting.publishers.discard(frames[1])
                    self._answer_if_joined(frames[2])
            elif frames[0] == BYE and len(frames) == 2:
                self._gone(frames[1])
        except (ValueError, TypeError, msgpack.ExtraData, msgpack.FormatError,
                msgpack.StackError):
            log.warning("bus proxy: dropped a malformed note from a publisher")

    def look(self) -> None:
        """Drop publishers whose process is gone; answer members past their patience, or
        those that waited for the grace to end."""
        if not self.waiting:
            return
        if time.monotonic() >= self._known_from:
            for topic in list(self.waiting):
                self._answer_if_joined(topic)
        for pub_id, pid in list(self.publishers.items()):
            if not alive(pid):
                self._gone(pub_id)
        now = time.monotonic()
        for topic, waiting in list(self.waiting.items()):
            if now >= waiting.deadline:
                log.warning("bus proxy: %d publisher(s) (pids %s) did not join a member "
                            "within %.1f s; answering it anyway", len(waiting.publishers),
                            sorted(self.publishers.get(p, 0) for p in waiting.publishers),
                            PATIENCE)
                waiting.publishers.clear()
                self._answer_if_joined(topic)

    def _gone(self, pub_id: bytes) -> None:
        self.publishers.pop(pub_id, None)
        for topic in list(self.waiting):
            self.waiting[topic].publishers.discard(pub_id)
            self._answer_if_joined(topic)

    def _answer_if_joined(self, topic: bytes) -> None:
        waiting = self.waiting.get(topic)
        if waiting is not None and not waiting.publishers and \
                time.monotonic() >= self._known_from:
            del self.waiting[topic]
            self.backend.send(topic)


def introduce(frontend: sockets.Socket, backend: sockets.Socket, control: sockets.Socket
              ) -> None:
    """Run the direct proxy until a message on `control` (its stop)."""
    state = Introducer(frontend, backend)
    poller = zmq.Poller()
    for sock in (frontend, backend, control):
        poller.register(sock, zmq.POLLIN)
    try:
        while True:
            ready = dict(poller.poll(_LOOK if state.waiting else None))
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
