"""Receiving messages from the bus by topic prefix: recv with a timeout, iterate, or callback."""

from __future__ import annotations

import threading
import time
from collections import deque
from collections.abc import Callable, Iterable, Iterator
from types import TracebackType

import zmq

from mrss.bus import direct, sockets
from mrss.bus.endpoints import BusEndpoints
from mrss.bus.incarnations import ANNOUNCEMENT, Incarnations, Stale
from mrss.bus.wire import WELCOME, WELCOME_DIRECT, message_frames
from mrss.errors import BusError, DecodeError
from mrss.messages import Envelope, decode

log = sockets.log

# How long a blocked recv waits before it looks whether close() was called.
_SLICE = 0.05
_SLICE_MS = int(_SLICE * 1000)
_NOBLOCK, _RCVMORE, _POLLIN = int(zmq.NOBLOCK), int(zmq.RCVMORE), int(zmq.POLLIN)


def _recv_multipart(sock: sockets.Socket) -> list[bytes]:
    """All frames of the next message (zmq.Again if none); leaner than recv_multipart."""
    frames = [sock.recv(_NOBLOCK)]
    while sock.getsockopt(_RCVMORE):
        frames.append(sock.recv(_NOBLOCK))
    return frames


class Subscriber:
    """Delivers the messages whose topic starts with one of `prefixes` ("" for all).

    Malformed messages are logged with topic and reason and dropped (`dropped` counts
    them). Reliable-channel data is delivered like any other message; acks and the
    proxy's welcome are not. After a proxy restart ZeroMQ reconnects and re-sends the
    subscriptions, so the subscriber carries on by itself. Messages of a dead or unproven
    incarnation, and replayed ones, are refused (`stale` counts them;
    mrss/bus/incarnations.py states the rule) unless `stale=Stale.KEEP`.

    `skip(topic)` refuses messages by topic before they are decoded, for a subscriber
    that needs some of a prefix's topics only (ZeroMQ filters by prefix alone): the
    reasoner takes `robot.<id>.state` but not the `robot.<id>.data` stream.

    Use one of `recv`, iteration or `start(callback)`; `close()` may be called from any
    thread and ends an iteration or a callback thread.
    """

    def __init__(
        self, endpoints: BusEndpoints, prefixes: Iterable[str] = ("",), *,
        hwm: int = sockets.DEFAULT_HWM, name: str = "subscriber",
        context: sockets.Context | None = None, stale: Stale = Stale.DROP,
        incarnations: Incarnations | None = None,
        skip: Callable[[bytes], bool] | None = None,
    ) -> None:
        if isinstance(prefixes, str):
            raise TypeError("prefixes must be a list of strings, not one string")
        self.endpoints = endpoints
        self.prefixes = tuple(prefixes)
        self._incarnations = None
        if stale is Stale.DROP:  # on a keyed bus, only proven incarnations are believed
            self._incarnations = incarnations or Incarnations(name)
            self._incarnations.adopt(endpoints.authority())
        # The supervisor's announcements teach the filter; delivered only when asked for.
        self._listen_only = self._incarnations is not None and not self._wants(ANNOUNCEMENT)
        self._early: deque[Envelope] = deque()
        self._batch: deque[tuple[bytes, bytes]] = deque()  # rest of a received batch
        self._skip = skip
        self.skipped = 0  # messages whose topic `skip` refused, never decoded
        self._drops = sockets.DropLog(name)
        self._lock = threading.Lock()
        self._close_lock = threading.Lock()
        self._closed = False
        self._connected = threading.Event()
        self.welcomes = 0  # proxy greetings: one more after each proxy restart
        self._thread: threading.Thread | None = None
        sock = sockets.connect(sockets.context(context), zmq.SUB, endpoints.backend, hwm=hwm)
        sock.setsockopt(zmq.SUBSCRIBE, WELCOME)
        for prefix in self.prefixes:
            sock.setsockopt(zmq.SUBSCRIBE, prefix.encode())
        if self._listen_only:
            sock.setsockopt(zmq.SUBSCRIBE, ANNOUNCEMENT.encode())
        self._sock = sock
        self._member: str | None = None  # the endpoint it binds on a direct bus
        self._membership = b""
        if endpoints.direct:
            self._become_member()
        self._poller = zmq.Poller()  # one for the socket's life: cheaper than sock.poll
        self._poller.register(sock, _POLLIN)

    def _become_member(self) -> None:
        """Bind an endpoint of its own and say so in a membership topic (direct.py, rule 1)."""
        prefixes = [p.encode() for p in self.prefixes]
        if self._listen_only:
            prefixes.append(ANNOUNCEMENT.encode())
        try:
            self._member = direct.bind_member(self._sock, self.endpoints)
        except zmq.ZMQError as exc:
            raise BusError(f"{self._drops.where}: cannot bind its direct endpoint: {exc}"
                           ) from exc
        self._membership = direct.membership_topic(self._member, tuple(prefixes))
        self._sock.setsockopt(zmq.SUBSCRIBE, self._membership)
        direct.KEEPER.add(id(self), self._touch)

    def _touch(self) -> None:
        """Let ZeroMQ take in publishers' connections while nobody receives (rule 7)."""
        if self._lock.acquire(blocking=False):
            try:
                if not self._closed:
                    self._sock.getsockopt(zmq.EVENTS)
            finally:
                self._lock.release()

    def _wants(self, topic: str) -> bool:
        return any(topic.startswith(prefix) for prefix in self.prefixes)

    @property
    def dropped(self) -> int:
        """How many malformed messages were dropped."""
        return self._drops.dropped

    @property
    def stale(self) -> int:
        """How many messages the incarnation rule refused (dead, unproven, replayed)."""
        return 0 if self._incarnations is None else self._incarnations.dropped

    def recv(self, timeout: float | None = None) -> Envelope | None:
        """The next message, or None when `timeout` seconds pass first (None: wait forever)."""
        incarnations = self._incarnations
        if incarnations is None:
            return self._recv_any(timeout)
        deadline = None if timeout is None else time.monotonic() + timeout
        while True:
            env = self._recv_any(timeout)
            if env is not None and incarnations.admit(env) and not (
                    self._listen_only and env.topic == ANNOUNCEMENT):
                return env
            if env is None or (deadline is not None and time.monotonic() >= deadline):
                return None
            if deadline is not None:
                timeout = max(0.0, deadline - time.monotonic())

    def _recv_any(self, timeout: float | None) -> Envelope | None:
        """The next well-formed message, live or not."""
        if self._early:
            return self._early.popleft()
        if self._batch:
            env = self._next_of_batch()
            if env is not None:
                return env
        return self._recv_next(timeout)

    def _decode(self, frames: list[bytes]) -> Envelope | None:
        """The (first) message in `frames`; None for control frames, malformed ones and
        topics to skip."""
        if self._skip is not None and self._skip(frames[0]):
            self.skipped += len(frames) - 1
            return None
        try:
            if len(frames) == 2 and frames[0][:4] != b"rel.":
                return decode(frames[0], frames[1])
            pairs = message_frames(frames)
        except DecodeError as exc:
            self._drops.drop(exc)
            return None
        if not pairs:
            self._greeted(frames[0])
            return None
        self._batch.extend(pairs)
        return self._next_of_batch()

    def _greeted(self, frame: bytes) -> None:
        """The proxy's welcome (or, on a direct bus, its answer to our membership)."""
        if frame == WELCOME or (frame == self._membership and frame):
            self.welcomes += 1
            self._connected.set()
        elif frame == WELCOME_DIRECT and self._member is None:
            with self._lock:  # a direct bus we were not told of: join it now
                if not self._closed:
                    self._become_member()

    def _next_of_batch(self) -> Envelope | None:
        """Decode the held messages of a batch until one is valid; None if none is."""
        while self._batch:
            try:
                return decode(*self._batch.popleft())
            except DecodeError as exc:
                self._drops.drop(exc)
        return None

    def _recv_next(self, timeout: float | None, until_greeted: bool = False
                   ) -> Envelope | None:
        """The next message; None after `timeout`, or (`until_greeted`) once greeted."""
        deadline = None if timeout is None else time.monotonic() + timeout
        while True:
            if self._batch:
                env = self._next_of_batch()
                if env is not None:
                    return env
            with self._lock:
                if self._closed:
                    raise BusError("subscriber is closed")
                frames = self._recv_frames(deadline)
            if frames is None:
                if deadline is not None and time.monotonic() >= deadline:
                    return None
                continue
            env = self._decode(frames)
            if env is not None or (until_greeted and self._connected.is_set()):
                return env

    def _recv_frames(self, deadline: float | None) -> list[bytes] | None:
        """One multipart message, or None after at most one time slice.

        One poll, which returns at once when a message is waiting, then the frames: no
        attempt that fails with zmq.Again first (raising it costs more than the poll,
        and a receiver that waits for each message, as in a request/reply, would pay it
        on every message).
        """
        if deadline is None:
            wait_ms = _SLICE_MS
        else:
            remaining = deadline - time.monotonic()
            wait_ms = 0 if remaining <= 0 else min(_SLICE_MS, int(remaining * 1000) or 1)
        if self._poller.poll(wait_ms):
            return _recv_multipart(self._sock)
        return None

    def __iter__(self) -> Iterator[Envelope]:
        """Every message until the subscriber is closed."""
        while True:
            try:
                env = self.recv(timeout=None)
            except BusError:
                return
            if env is not None:
                yield env

    def fileno(self) -> int:
        """The socket's descriptor, for an event loop's reader (instead of a thread).

        It is edge-triggered: readable says messages *may* have arrived; take them all
        with `take_ready`, which also rearms it. Then no thread wakes while nothing comes.
        """
        return int(self._sock.getsockopt(zmq.FD))

    def take_ready(self, limit: int = 10_000) -> list[Envelope]:
        """Every message waiting now (at most `limit`), without waiting; [] once closed."""
        taken: list[Envelope] = []
        try:
            while len(taken) < limit:
                env = self.recv(timeout=0)
                if env is None:
                    break
                taken.append(env)
        except BusError:
            pass
        return taken

    def wait_connected(self, timeout: float = 5.0) -> bool:
        """Whether the proxy has greeted this subscriber (its subscriptions are on the way).

        Messages that arrive meanwhile are kept for `recv`. Call it from the thread that
        receives, or after `start`.
        """
        if self._thread is None:
            deadline = time.monotonic() + timeout
            while not self._connected.is_set():
                remaining = deadline - time.monotonic()
                if remaining <= 0:
                    return False
                env = self._recv_next(min(remaining, _SLICE), until_greeted=True)
                if env is not None:
                    self._early.append(env)
            return True
        return self._connected.wait(timeout)

    def start(self, callback: Callable[[Envelope], object]) -> None:
        """Call `callback(env)` for every message on a background thread until `close()`.

        An exception in the callback is logged and the thread carries on.
        """
        if self._closed:
            raise BusError("subscriber is closed")
        if self._thread is not None:
            raise BusError("subscriber already has a callback thread")

        def deliver() -> None:
            for env in self:
                try:
                    callback(env)
                except Exception:
                    log.exception("%s: callback failed on %s", self._drops.where, env.topic)

        self._thread = threading.Thread(target=deliver, name=f"mrss-sub-{self._drops.where}",
                                        daemon=True)
        self._thread.start()

    def close(self) -> None:
        """Stop the callback thread or iteration, and close the socket."""
        # Not under `_lock`: the receiving thread holds it while it polls and takes it
        # again at once, so a closer waiting for it could starve (it did, under SCHED_RR);
        # the receiver sees the flag within one poll slice.
        with self._close_lock:
            if self._closed:
                return
            self._closed = True
        thread = self._thread
        if thread is not None and thread is not threading.current_thread():
            thread.join(timeout=5)
        with self._lock:
            self._sock.close(0)
        if self._member is not None:
            direct.KEEPER.remove(id(self))
            direct.forget_member(self._member)

    def __enter__(self) -> Subscriber:
        return self

    def __exit__(self, exc_type: type[BaseException] | None, exc: BaseException | None,
                 tb: TracebackType | None) -> None:
        self.close()
