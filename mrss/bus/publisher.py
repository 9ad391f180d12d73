"""Publishing messages on the bus: encode, then send through the proxy's frontend.

One idea in one module, on purpose (~460 lines): batching, the flusher and the
connection state share one lock and one send path on the hottest path of the system;
splitting them would put a call or a lock between every publish and its socket.

A message goes out at once unless it follows the previous one within `BURST_GAP`
(20 us): then it joins a batch, a single ZeroMQ message `[topic, envelope, envelope,
...]` of consecutive messages on one topic, which every hop handles in one go. A batch
is sent when it is full (`MAX_BATCH` messages or `MAX_BATCH_BYTES`), when the topic
changes, when it is `MAX_HOLD` old at the next publish, or else by a flusher thread once
publishing has paused for `FLUSH_IDLE` (50 us; a few milliseconds at worst, when other
Python threads hold the GIL). So isolated messages (requests, replies, statuses) never
wait, and streams cost a fraction per message. Subscribers unpack batches transparently.

A caller that knows its messages belong together says so: inside `gathering()`, what a
thread publishes on one topic is held and sent as one batch when the block ends (the
RCL sends the records of one telemetry sample of a robot so: three messages, one on
the wire); a message on another topic sends the held ones first and goes at once.
"""

from __future__ import annotations

import select
import threading
import time
from collections import deque
from collections.abc import Callable, Iterator
from contextlib import contextmanager
from types import TracebackType

import zmq

from mrss.bus import sockets
from mrss.bus.direct import MARKER, MEMBER, PATIENCE
from mrss.bus.direct_route import DirectRoute
from mrss.bus.endpoints import BusEndpoints
from mrss.bus.forwarder import bind_endpoint, clear_stale_socket
from mrss.bus.wire import WELCOME
from mrss.errors import BusError
from mrss.messages import IdGenerator, Message, encode

BURST_GAP = 20e-6
MAX_BATCH = 64
MAX_BATCH_BYTES = 16_384
MAX_HOLD = 0.001
FLUSH_IDLE = 50e-6  # the flusher sends a held batch once publishing paused this long
# Subscription notices from the proxy queue up on our XPUB socket; read them now and then.
_DRAIN_EVERY = 512
_SNDMORE = int(zmq.SNDMORE)
_WATCHED = 256  # subscription notices kept for `subscriptions()`


class Publisher:
    """Sends messages to every subscriber of their topic; thread-safe.

    Plain publish/subscribe: a message sent while the proxy is down or restarting is
    queued (up to `hwm` ZeroMQ messages) and sent on reconnect, but may be lost around a
    crash. Use the reliable channel where a loss matters. Messages of one publisher
    arrive in the order published. Messages published before the proxy first
    subscribed to this publisher are held (up to `hwm`) and sent once it has, by a
    short-lived joiner thread, so a component's first words are not lost.

    The socket is an XPUB connected to the proxy's XSUB, so the publisher can tell when
    the proxy has subscribed to it (`wait_connected`): a short-lived sender such as
    `mrss send` waits for that before its one message. With `watch_subscriptions` it
    also reports every subscription the proxy passes on, repeats included
    (`subscriptions()`): the root supervisor learns so when a subscriber of its events
    has joined a restarted proxy.

    With `bind` the publisher binds `endpoints.frontend` itself instead of connecting to
    a proxy there, and subscribers connect straight to it (as their backend): no proxy
    hop, about half the round trip (docs/bus.md, "Limits"). "Connected" then means a
    subscriber has subscribed to a prefix (its welcome topic does not count: it can
    arrive before the prefixes); for a subscriber of several prefixes, the first.
    Nothing announces such a publisher, so its subscribers must be told where it is
    (the bus's direct delivery does not use it: mrss/bus/direct.py).
    """

    def __init__(
        self, endpoints: BusEndpoints, src: str, inc: int = 0, *,
        hwm: int = sockets.DEFAULT_HWM, linger: float = 1.0, batching: bool = True,
        context: sockets.Context | None = None, watch_subscriptions: bool = False,
        bind: bool = False,
    ) -> None:
        self.src = src
        self.inc = inc
        self.cred = endpoints.credential(src, inc)  # proof of (src, inc) on a keyed bus
        self.operator = ""  # a dashboard's session credential, sent with every message
        self.endpoints = endpoints
        self._ids = IdGenerator()
        self._lock = threading.Lock()
        self._bound = bind
        self._ctx = sockets.context(context)
        self._hwm, self._linger_ms = hwm, int(linger * 1000)
        self._route: DirectRoute | None = None  # on a direct bus (mrss/bus/direct.py)
        self._early_members: list[bytes] = []  # membership notices before the marker
        if bind:
            self._sock: sockets.Socket | None = bound_socket(
                sockets.context(context), endpoints.frontend, hwm=hwm,
                linger_ms=int(linger * 1000))
        else:
            self._sock = sockets.connect(
                sockets.context(context), zmq.XPUB, endpoints.frontend, hwm=hwm,
                linger_ms=int(linger * 1000))
        self._connected = False
        self._sent = 0
        self._batching = batching
        self._batch: list[bytes] = []  # [topic, envelope, envelope, ...] not yet sent
        self._batch_bytes = 0
        self._batch_since = 0.0
        self._last_publish = 0.0
        self._flusher: threading.Thread | None = None
        self._flusher_idle = False
        self.batches_sent = 0  # ZeroMQ messages that carried more than one message
        self._wake = threading.Condition(self._lock)
        self._held: deque[tuple[bytes, ...]] = deque(maxlen=hwm)
        self._joiner: threading.Thread | None = None
        self._watch = watch_subscriptions
        self._gathered = threading.local()  # .held: this thread's messages in `gathering`
        self._subscribed: deque[bytes] = deque(maxlen=_WATCHED)
        if watch_subscriptions:  # repeats too: a restarted proxy subscribes again
            self._sock.setsockopt(zmq.XPUB_VERBOSE, 1)

    def publish(self, msg: Message, topic: str | None = None) -> str:
        """Send `msg` on `topic` (default: the message's own topic); return its id."""
        msg_id = self._ids()
        topic_frame, payload = encode(msg, src=self.src, inc=self.inc, msg_id=msg_id,
                                      topic=topic, cred=self.cred, op=self.operator)
        held = getattr(self._gathered, "held", None)
        if held is not None:
            if not held or held[0][0] == topic_frame:
                held.append((topic_frame, payload))
                return msg_id
            self._send_gathered(held)  # another topic: no waiting behind the held ones
        with self._lock:
            sock = self._sock
            if sock is None:
                raise BusError("publisher is closed")
            if (not self._connected or self._held) and self._hold((topic_frame, payload), sock):
                return msg_id
            sock = self._socket()  # going direct (in _hold) swaps it
            now = time.perf_counter()
            burst = self._batching and now - self._last_publish < BURST_GAP
            self._last_publish = now
            batch = self._batch
            if batch and (not burst or batch[0] != topic_frame
                          or now - self._batch_since > MAX_HOLD):
                self._send_batch(sock)
            if burst or self._batch:
                self._add_to_batch(sock, topic_frame, payload, now)
            else:
                # Two plain sends cost half of one send_multipart.
                sock.send(topic_frame, _SNDMORE)
                sock.send(payload)
                self._count_sent(sock)
        return msg_id

    def _add_to_batch(self, sock: sockets.Socket, topic: bytes, payload: bytes,
                      now: float) -> None:
        # Caller holds the lock.
        if not self._batch:
            self._batch = [topic]
            self._batch_since = now
            self._ensure_flusher()
        self._batch.append(payload)
        self._batch_bytes += len(payload)
        if len(self._batch) > MAX_BATCH or self._batch_bytes >= MAX_BATCH_BYTES:
            self._send_batch(sock)

    def _send_batch(self, sock: sockets.Socket) -> None:
        # Caller holds the lock.
        batch, self._batch, self._batch_bytes = self._batch, [], 0
        self.batches_sent += len(batch) > 2
        last = len(batch) - 1
        for i, frame in enumerate(batch):
            sock.send(frame, _SNDMORE if i < last else 0)
        self._count_sent(sock)

    @property
    def sends(self) -> int:
        """How many ZeroMQ messages went out (a batch counts once).

        Read under the lock: a joiner or direct-route thread sends, then counts, both
        under the lock, and a subscriber may receive the message in between; unlocked,
        this could say less than what has already arrived.
        """
        with self._lock:
            return self._sent

    def _count_sent(self, sock: sockets.Socket) -> None:
        self._sent += 1
        if self._sent % _DRAIN_EVERY == 0:
            self._drain_subscriptions(sock)

    def _ensure_flusher(self) -> None:
        # Caller holds the lock.
        if self._flusher is None:
            self._flusher = threading.Thread(target=self._flush_forever, daemon=True,
                                             name=f"mrss-pub-flush-{self.src}")
            self._flusher.start()
        elif self._flusher_idle:
            self._wake.notify()

    def _flush_forever(self) -> None:
        """Send a held batch once its publisher pauses; ends when the publisher closes.

        While a burst goes on the publisher sends its own full or old batches, so the
        flusher then sleeps until the current batch's `MAX_HOLD` deadline instead of
        waking (and taking the GIL) every few microseconds.
        """
        with self._lock:
            while self._sock is not None:
                if not self._batch:
                    self._flusher_idle = True
                    self._wake.wait()
                    self._flusher_idle = False
                    continue
                now = time.perf_counter()
                if now - self._last_publish < FLUSH_IDLE:
                    self._wake.wait(max(FLUSH_IDLE, self._batch_since + MAX_HOLD - now))
                    continue
                self._send_batch(self._sock)

    @contextmanager
    def gathering(self) -> Iterator[None]:
        """Hold what this thread publishes on one topic until the block ends (even by an
        exception) and send it then as one batch. A message on another topic sends what
        is held first and goes at once (a request waits for nothing held: its reply can
        come). Other threads publish as usual meanwhile; a nested block joins the outer
        one."""
        if getattr(self._gathered, "held", None) is not None:
            yield
            return
        held: list[tuple[bytes, bytes]] = []
        self._gathered.held = held
        try:
            yield
        finally:
            self._gathered.held = None
            self._send_gathered(held)

    def _send_gathered(self, held: list[tuple[bytes, bytes]]) -> None:
        """Send what a gathering held (all on one topic) as batches of at most
        `MAX_BATCH` messages and about `MAX_BATCH_BYTES`."""
        if not held:
            return
        topic = held[0][0]
        frames, size = [topic], 0
        for _, payload in held:
            if len(frames) > MAX_BATCH or size >= MAX_BATCH_BYTES:
                self.send_frames(frames)
                frames, size = [topic], 0
            frames.append(payload)
            size += len(payload)
        self.send_frames(frames)
        held.clear()

    def flush(self) -> None:
        """Send a held batch now."""
        with self._lock:
            if self._batch and self._sock is not None:
                self._send_batch(self._sock)

    def send_frames(self, frames: tuple[bytes, ...] | list[bytes]) -> None:
        """Send an already encoded multipart message (for relays and the reliable channel)."""
        with self._lock:
            sock = self._socket()
            if (not self._connected or self._held) and self._hold(tuple(frames), sock):
                return
            sock = self._socket()  # going direct (in _hold) swaps it
            if self._batch:
                self._send_batch(sock)  # keep the publisher's order
            last = len(frames) - 1
            for i, frame in enumerate(frames):
                sock.send(frame, _SNDMORE if i < last else 0)
            self._count_sent(sock)

    def wait_connected(self, timeout: float = 5.0) -> bool:
        """Wait until the proxy has subscribed to this publisher; False on timeout.

        The lock is held only to read the socket, never while waiting, so other threads
        publish (their messages held meanwhile) without waiting for this one.
        """
        deadline = time.monotonic() + timeout
        while True:
            with self._lock:
                sock = self._socket()
                self._drain_subscriptions(sock)
                if self._connected and (self._route is None or not self._held):
                    return True  # (direct: and what it held has gone out)
                remaining = deadline - time.monotonic()
                if remaining <= 0:
                    return False
                if self._route is not None:  # its watcher says when members join
                    self._route.changed.wait(min(remaining, 0.05))
                    continue
                fd = int(sock.getsockopt(zmq.FD))
            # ZeroMQ's descriptor signals news for the socket, but another thread's send may
            # consume the signal: wait in short slices and look again.
            try:
                select.select([fd], [], [], min(remaining, 0.05))
            except (OSError, ValueError):
                pass  # closed meanwhile: the next look says so

    def _drain_subscriptions(self, sock: sockets.Socket) -> None:
        """Read the subscription notices: the proxy's, or on a direct bus the members'."""
        if self._route is not None:
            self._route.take_news()
            self._connected = self._route.ready
            return
        while True:
            try:
                notice = sock.recv(zmq.NOBLOCK)
            except zmq.Again:
                return
            first = notice[1:2]
            if first == MEMBER:  # a direct bus's member (a stray one on a plain bus)
                if not self._connected:
                    self._early_members.append(notice)
            elif first == MARKER and notice[:1] == b"\x01":
                self._go_direct(sock)
                self._drain_subscriptions(sock)  # what the proxy said after its marker
                return
            elif notice[:1] == b"\x01":
                # A plain proxy takes everything: it is there. Bound: a subscriber's first
                # prefix, not its welcome (which sorts, and may arrive, before them).
                if notice == b"\x01" or (self._bound and notice[1:] != WELCOME):
                    self._connected = True
                    self._early_members.clear()
                if self._watch:
                    self._subscribed.append(notice[1:])

    def _go_direct(self, control: sockets.Socket) -> None:
        """The proxy said the bus is direct: deliver to its members (lock held)."""
        data = sockets.connecting(self._ctx, zmq.XPUB, hwm=self._hwm, linger_ms=self._linger_ms)
        # Every join reported, even one whose topic the socket still holds from a link
        # it is dropping: a member learnt again must not wait out the patience.
        data.setsockopt(zmq.XPUB_VERBOSE, 1)
        control.setsockopt(zmq.XPUB_VERBOSE, 1)  # a restarted proxy's repeats too
        watched = self._subscribed if self._watch else deque(maxlen=0)
        route = DirectRoute(control, data, self._lock, self._release_direct, self.src, watched)
        for notice in self._early_members:
            route.on_control(notice)
        self._early_members.clear()
        self._route, self._sock = route, data
        self._connected = route.ready
        route.start()

    def _release_direct(self) -> bool:
        """Send the held messages no joining member waits for, in order (lock held);
        True if some still wait."""
        route, sock = self._route, self._sock
        if route is None or sock is None:
            return False
        self._connected = route.ready
        if self._held and self._batch:
            self._send_batch(sock)  # it was published before them
        self._send_held(sock, until=route.must_hold)
        return bool(self._held)

    def subscriptions(self) -> list[str]:
        """Topic prefixes subscribed through the proxy since the last call (with
        `watch_subscriptions`; "" is the proxy itself taking everything)."""
        with self._lock:
            self._drain_subscriptions(self._socket())
            found = [t.decode("utf-8", "replace") for t in self._subscribed]
            self._subscribed.clear()
        return found

    def _hold(self, frames: tuple[bytes, ...], sock: sockets.Socket) -> bool:
        """Hold `frames` while the proxy has not subscribed yet, or on a direct bus while a
        member that wants them joins (lock held); False if they may go."""
        self._drain_subscriptions(sock)
        if self._route is not None:
            if not self._held and not self._route.must_hold(frames[0]):
                return False
            self._held.append(frames)  # the route's watcher releases them
            return True
        if self._connected and not self._held:
            return False
        self._held.append(frames)
        if self._connected:
            self._send_held(sock)
        elif self._joiner is None:
            self._joiner = threading.Thread(target=self._join, name=f"mrss-pub-join-{self.src}",
                                            daemon=True)
            self._joiner.start()
        return True

    def _send_held(self, sock: sockets.Socket,
                   until: Callable[[bytes], bool] | None = None) -> None:
        """Send held messages in order: all, or up to the first whose topic `until` holds."""
        while self._held and not (until is not None and until(self._held[0][0])):
            frames = self._held.popleft()
            last = len(frames) - 1
            for i, frame in enumerate(frames):
                sock.send(frame, _SNDMORE if i < last else 0)
            self._sent += 1

    def _join(self) -> None:
        """Wait for the proxy's subscription, then send what was held."""
        while True:
            try:
                connected = self.wait_connected(timeout=0.5)
            except BusError:
                return  # closed meanwhile
            if connected:
                with self._lock:
                    if self._route is not None:
                        self._release_direct()
                    elif self._sock is not None:
                        self._send_held(self._sock)
                    self._joiner = None
                return

    def _socket(self) -> sockets.Socket:
        if self._sock is None:
            raise BusError("publisher is closed")
        return self._sock

    def close(self) -> None:
        """Send what is held, close; queued messages get `linger` seconds to go out."""
        with self._lock:
            if self._sock is None:
                return
            route = self._route
            if route is not None:  # let members that are joining have what waits for them
                deadline = time.monotonic() + PATIENCE + 0.5
                while self._held and time.monotonic() < deadline:
                    route.changed.wait(0.05)
            if self._batch:
                self._send_batch(self._sock)
            self._sock.close()
            self._sock = None
            if route is not None:
                route.close()
            self._wake.notify_all()
            if self._bound:
                for path in BusEndpoints.paths_of([self.endpoints.frontend]):
                    path.unlink(missing_ok=True)
        if self._flusher is not None and self._flusher is not threading.current_thread():
            self._flusher.join(timeout=5)
        if route is not None:
            route.join()

    def __enter__(self) -> Publisher:
        return self

    def __exit__(self, exc_type: type[BaseException] | None, exc: BaseException | None,
                 tb: TracebackType | None) -> None:
        self.close()


def bound_socket(ctx: sockets.Context, endpoint: str, *, hwm: int, linger_ms: int
                 ) -> sockets.Socket:
    """An XPUB bound to `endpoint` (a stale ipc file of a killed owner is removed first)."""
    for path in BusEndpoints.paths_of([endpoint]):
        clear_stale_socket(path)
    sock = ctx.socket(zmq.XPUB)
    sock.setsockopt(zmq.LINGER, linger_ms)
    sock.setsockopt(zmq.SNDHWM, hwm)
    sock.setsockopt(zmq.RCVHWM, hwm)
    try:
        bind_endpoint(sock, endpoint)
    except BusError:
        sock.close(0)
        raise
    return sock
