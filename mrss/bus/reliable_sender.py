"""The sending end of a reliable channel: repeat each message until it is acknowledged.

Messages get consecutive sequence numbers in a sender session (16 random bytes, new
for every ReliableSender). At most `window` of them are on the wire unacknowledged; the
rest wait here. The receiver acknowledges cumulatively ("I have everything up to N"),
so one small ack covers a whole burst. When no ack has advanced for `resend_after`
seconds, everything in flight that old is sent again, and the wait doubles up to
`max_resend_after` until acks flow again. Nothing is ever given up on: `pending()`
tells how many messages are not yet acknowledged, and `flush()` waits for none.
`when_acked(callback)` calls back once everything sent before it is acknowledged (the
events manager acknowledges an MQTT message to its broker so, once the reasoner has its
percepts); callbacks still waiting when the sender closes are dropped, never called.
"""

from __future__ import annotations

import os
import threading
import time
from collections import deque
from collections.abc import Callable
from types import TracebackType

import zmq

from mrss.bus import direct, sockets, wire
from mrss.bus.endpoints import BusEndpoints
from mrss.bus.publisher import Publisher
from mrss.errors import BusError, DecodeError
from mrss.messages import IdGenerator, Message, encode

log = sockets.log

DEFAULT_WINDOW = 1024


class _Outgoing:
    """One unacknowledged message: its two message frames and when it last went out."""

    __slots__ = ("topic", "payload", "sent_at")

    def __init__(self, topic: bytes, payload: bytes) -> None:
        self.topic = topic
        self.payload = payload
        self.sent_at = 0.0  # never sent


class ReliableSender:
    """Sends messages on `channel` until a ReliableReceiver acknowledges each one; thread-safe."""

    def __init__(
        self, endpoints: BusEndpoints, src: str, inc: int = 0, channel: str = "action", *,
        window: int = DEFAULT_WINDOW, resend_after: float = 0.2, max_resend_after: float = 1.0,
        context: sockets.Context | None = None,
    ) -> None:
        self.channel = wire.check_channel(channel)
        if window < 1:
            raise ValueError("window must be at least 1")
        self.src, self.inc = src, inc
        self._window = window
        self._resend_after = self._initial_resend = resend_after
        self._max_resend = max_resend_after
        self._session = os.urandom(wire.SESSION_BYTES)
        self._ids = IdGenerator()
        self._data_topic = wire.data_topic(channel)
        ctx = sockets.context(context)
        self._pub = Publisher(endpoints, src, inc, context=ctx)
        self._acks, self._member = direct.subscriber_socket(
            ctx, endpoints, [wire.ack_topic(channel, self._session)])
        self._lock = threading.Lock()
        self._all_acked = threading.Condition(self._lock)
        self._pending: dict[int, _Outgoing] = {}
        self._next_seq = 1
        self._base = 1  # lowest unacknowledged sequence number
        self._last_progress = time.monotonic()
        # (highest sequence number it waits for, callback), in sending order
        self._waiters: deque[tuple[int, Callable[[], object]]] = deque()
        self.resent = 0  # how many times a message went out again
        self._closed = threading.Event()
        self._thread = threading.Thread(target=self._serve, daemon=True,
                                        name=f"mrss-reliable-tx-{channel}")
        self._thread.start()

    def send(self, msg: Message, topic: str | None = None, msg_id: str | None = None) -> str:
        """Queue `msg` for delivery and return its id; it is repeated until acknowledged."""
        msg_id = msg_id or self._ids()
        frames = encode(msg, src=self.src, inc=self.inc, msg_id=msg_id, topic=topic,
                        cred=self._pub.cred)
        out = _Outgoing(*frames)
        with self._lock:
            if self._closed.is_set():
                raise BusError(f"reliable sender on channel {self.channel!r} is closed")
            seq = self._next_seq
            self._next_seq += 1
            if not self._pending:
                self._last_progress = time.monotonic()
            self._pending[seq] = out
            if seq < self._base + self._window:
                self._transmit(seq, out, time.monotonic())
        return msg_id

    def when_acked(self, callback: Callable[[], object]) -> None:
        """Call `callback()` once every message sent so far is acknowledged: now, on this
        thread, when none is pending; else on the sender's thread, in the order asked.
        Dropped (not called) if the sender closes first."""
        with self._lock:
            if self._pending or self._waiters:  # in order behind earlier waiters
                self._waiters.append((self._next_seq - 1, callback))
                return
        callback()

    def pending(self) -> int:
        """How many sent messages are not acknowledged yet."""
        with self._lock:
            return len(self._pending)

    def flush(self, timeout: float | None = None) -> bool:
        """Wait until every message is acknowledged; False if `timeout` passes first."""
        with self._all_acked:
            return self._all_acked.wait_for(lambda: not self._pending, timeout)

    def _transmit(self, seq: int, out: _Outgoing, now: float) -> None:
        # Caller holds the lock.
        header = wire.pack_header(self._session, seq, self._base)
        self._pub.send_frames((self._data_topic, out.topic, out.payload, header))
        out.sent_at = now

    def _serve(self) -> None:
        """Background: take acks, open the window, repeat what is overdue."""
        tick = max(0.005, min(0.05, self._initial_resend / 4))
        try:
            while not self._closed.is_set():
                watermark = 0
                if self._acks.poll(int(tick * 1000), zmq.POLLIN):
                    watermark = self._read_acks()
                due: list[Callable[[], object]] = []
                with self._lock:
                    now = time.monotonic()
                    if watermark >= self._base:
                        self._acknowledge(watermark, now)
                    elif self._pending and now - self._last_progress >= self._resend_after:
                        self._resend_overdue(now)
                    while self._waiters and self._waiters[0][0] < self._base:
                        due.append(self._waiters.popleft()[1])
                for callback in due:
                    self._call(callback)
        except Exception:
            log.exception("reliable sender on channel %r failed", self.channel)
            raise

    def _call(self, callback: Callable[[], object]) -> None:
        try:
            callback()
        except Exception:  # a waiter's bug must not stop the channel
            log.exception("channel %r: a when_acked callback failed", self.channel)

    def _read_acks(self) -> int:
        best = 0
        for _ in range(1000):
            try:
                frames = self._acks.recv_multipart(zmq.NOBLOCK)
            except zmq.Again:
                break
            if wire.is_answer(frames):
                continue
            try:
                if len(frames) != 2:
                    raise DecodeError(f"ack of {len(frames)} frames")
                session, watermark = wire.unpack_ack(frames[1])
            except DecodeError as exc:
                log.warning("channel %r: dropped malformed ack: %s", self.channel, exc.reason)
                continue
            if session == self._session:
                best = max(best, watermark)
        return best

    def _acknowledge(self, watermark: int, now: float) -> None:
        # Caller holds the lock.
        top = min(watermark, self._next_seq - 1)
        old_limit = self._base + self._window
        for seq in range(self._base, top + 1):
            self._pending.pop(seq, None)
        self._base = top + 1
        self._last_progress = now
        self._resend_after = self._initial_resend
        for seq in range(max(old_limit, self._base),
                         min(self._base + self._window, self._next_seq)):
            self._transmit(seq, self._pending[seq], now)
        if not self._pending:
            self._all_acked.notify_all()

    def _resend_overdue(self, now: float) -> None:
        # Caller holds the lock.
        limit = min(self._base + self._window, self._next_seq)
        resent = 0
        for seq in range(self._base, limit):
            out = self._pending[seq]
            if now - out.sent_at >= self._resend_after:
                self._transmit(seq, out, now)
                resent += 1
        self.resent += resent
        log.debug("channel %r: resent %d message(s) after %.2fs without ack", self.channel,
                  resent, self._resend_after)
        self._last_progress = now
        self._resend_after = min(self._resend_after * 2, self._max_resend)

    def close(self) -> None:
        """Stop repeating; messages still unacknowledged are given up (and logged)."""
        with self._lock:
            if self._closed.is_set():
                return
            self._closed.set()
            left = len(self._pending)
            self._waiters.clear()
        self._thread.join(timeout=5)
        self._acks.close(0)
        direct.forget_member(self._member)
        self._pub.close()
        if left:
            log.warning("reliable sender on channel %r closed with %d unacknowledged",
                        self.channel, left)

    def __enter__(self) -> ReliableSender:
        return self

    def __exit__(self, exc_type: type[BaseException] | None, exc: BaseException | None,
                 tb: TracebackType | None) -> None:
        self.close()
