"""A publisher's direct links to the members of a direct bus (mrss/bus/direct.py, rules 3-4).

`DirectRoute` keeps the members the proxy told of (on the publisher's control socket,
connected to the proxy) and the data socket connected to each of them; it knows which
have joined (their membership came back on the data socket) and says which messages
must wait for one that has not (`must_hold`). A watcher thread reads both sockets, under
the publisher's lock, and lets the publisher release what it held whenever that changes.
"""

from __future__ import annotations

import logging
import os
import select
import threading
import time
from collections import deque
from collections.abc import Callable
from dataclasses import dataclass, field

import msgpack
import zmq

from mrss.bus import sockets
from mrss.bus.direct import MARKER, MEMBER, PATIENCE, SWEEP, Membership, alive, read_membership
from mrss.bus.wire import BYE, HELLO, JOINED

log = logging.getLogger("mrss.bus")

BUSY_SLICE = 0.002  # seconds between looks while a member is joining or messages are held
IDLE_SLICE = 0.25   # otherwise (the control socket's descriptor wakes the watcher at once)
_SUBSCRIBE = b"\x01"


@dataclass
class _Member:
    membership: Membership
    since: float = field(default_factory=time.monotonic)
    joined: bool = False


class DirectRoute:
    """Members, their joins and departures; all methods but `start` with the lock held."""

    def __init__(self, control: sockets.Socket, data: sockets.Socket, lock: threading.Lock,
                 release: Callable[[], bool], name: str, watched: deque[bytes]) -> None:
        self.control = control
        self.data = data
        self._lock = lock
        self._release = release  # sends held messages that may go; True if some still wait
        self._name = name
        self._members: dict[bytes, _Member] = {}
        self._waiting: dict[bytes, _Member] = {}  # not joined, within PATIENCE
        self._watched = watched  # data prefixes subscribed through the proxy
        self._closed = False
        self._id = os.urandom(8)  # who we are to the proxy (introducer.py)
        # A member learnt by a publishing thread wakes the watcher, which waits for its join.
        self._wake_r, self._wake_w = os.pipe()
        os.set_blocking(self._wake_w, False)
        self.changed = threading.Condition(lock)
        self._thread = threading.Thread(target=self._watch, name=f"mrss-pub-direct-{name}",
                                        daemon=True)

    def start(self) -> None:
        """Say hello to the proxy and start the watcher (lock held)."""
        self._hello()
        self._thread.start()

    def _hello(self) -> None:
        self.control.send_multipart([HELLO, msgpack.packb([self._id, os.getpid()])])

    def _joined(self, topic: bytes) -> None:
        self.control.send_multipart([JOINED, self._id, topic])

    @property
    def ready(self) -> bool:
        """No member the proxy told of is still joining."""
        return not self._waiting

    @property
    def members(self) -> int:
        return len(self._members)

    def must_hold(self, topic: bytes) -> bool:
        """Whether a member that wants `topic` has not joined yet."""
        return any(m.membership.wants(topic) for m in self._waiting.values())

    def take_news(self) -> None:
        """Read what the proxy and the members said since the last look."""
        self._take(self.control, self.on_control)
        self._take(self.data, self._on_data)

    @staticmethod
    def _take(sock: sockets.Socket, handle: Callable[[bytes], None]) -> None:
        while True:
            try:
                frames = sock.recv_multipart(zmq.NOBLOCK)
            except zmq.Again:
                return
            handle(frames[0])

    def on_control(self, notice: bytes) -> None:
        topic = notice[1:]
        subscribed = notice[:1] == _SUBSCRIBE
        if topic[:1] == MEMBER:
            if subscribed:
                member = self._members.get(topic)
                if member is None:
                    self._learn(topic)
                elif member.joined:
                    self._joined(topic)  # a restarted proxy asks again
            elif topic in self._members:
                self._forget(topic)  # it left the proxy: closed, or died
        elif topic[:1] == MARKER:
            if subscribed:  # a (restarted) proxy: it must know us, and whom we joined
                self._hello()
                for known, member in self._members.items():
                    if member.joined:
                        self._joined(known)
        elif subscribed:
            self._watched.append(topic)

    def _learn(self, topic: bytes) -> None:
        membership = read_membership(topic)
        if membership is None:
            log.warning("%s: ignored a malformed membership %r", self._name, topic[:80])
            return
        try:
            self.data.connect(membership.endpoint)
        except zmq.ZMQError as exc:
            log.warning("%s: cannot connect to member %s: %s", self._name,
                        membership.endpoint, exc)
            return
        member = _Member(membership)
        self._members[topic] = self._waiting[topic] = member
        if threading.current_thread() is not self._thread:
            try:
                os.write(self._wake_w, b"!")
            except BlockingIOError:
                pass  # woken already

    def _on_data(self, notice: bytes) -> None:
        """A member's subscription on the data socket: it has joined.

        Unsubscriptions are ignored: a member never withdraws its membership (its socket
        just closes, and our connecting pipe to it lives on), so the only ones here are
        the echo of our own `disconnect` in `_forget`, read later. Taken as a leave, that
        echo undid a member forgotten and learnt again meanwhile (its proxy link dropped
        and came back): the publisher disconnected it for good and sent it nothing more.
        """
        topic = notice[1:]
        if topic[:1] != MEMBER or notice[:1] != _SUBSCRIBE:
            return
        member = self._members.get(topic)
        if member is not None and not member.joined:
            member.joined = True
            self._waiting.pop(topic, None)
            self._joined(topic)

    def _forget(self, topic: bytes) -> None:
        member = self._members.pop(topic)
        self._waiting.pop(topic, None)
        try:
            self.data.disconnect(member.membership.endpoint)
        except zmq.ZMQError:
            pass  # never connected, or already gone

    def _sweep(self) -> None:
        """Forget members whose process is gone (rule 4: the proxy may have missed it)."""
        for topic, member in list(self._members.items()):
            if not alive(member.membership.pid):
                self._forget(topic)

    def _expire(self) -> None:
        now = time.monotonic()
        for topic, member in list(self._waiting.items()):
            if now - member.since > PATIENCE:
                del self._waiting[topic]
                log.warning("%s: member %s did not join within %.1f s; sending without it",
                            self._name, member.membership.endpoint, PATIENCE)

    def _watch(self) -> None:
        """Read both sockets, release what may go, sleep until something is said."""
        next_sweep = time.monotonic() + SWEEP
        while True:
            with self._lock:
                if self._closed:
                    return
                try:
                    self.take_news()
                    self._expire()
                    if time.monotonic() >= next_sweep:
                        self._sweep()
                        next_sweep = time.monotonic() + SWEEP
                    busy = self._release() or bool(self._waiting)
                    # The data socket only while a member joins: streaming keeps waking
                    # its descriptor, and a leave is told on the control socket.
                    fds = [int(self.control.getsockopt(zmq.FD)), self._wake_r]
                    if busy:
                        fds.append(int(self.data.getsockopt(zmq.FD)))
                except zmq.ZMQError:
                    return  # closed meanwhile
                self.changed.notify_all()
            try:
                readable, _, _ = select.select(fds, [], [], BUSY_SLICE if busy else IDLE_SLICE)
                if self._wake_r in readable:
                    os.read(self._wake_r, 64)
            except (OSError, ValueError):
                pass  # closed meanwhile: the next look says so

    def close(self) -> None:
        """Stop the watcher (the publisher closes the sockets, lock held)."""
        self._closed = True
        self.changed.notify_all()
        try:
            self.control.send_multipart([BYE, self._id])
        except zmq.ZMQError:
            pass  # closing anyway
        self.control.close()

    def join(self) -> None:
        """Wait for the watcher to end, then close the wake pipe."""
        if self._thread is not threading.current_thread():
            self._thread.join(timeout=5)
        for fd in (self._wake_r, self._wake_w):
            try:
                os.close(fd)
            except OSError:
                pass
