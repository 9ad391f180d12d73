"""The receiving end of a reliable channel: each message to the handler exactly once, in order.

Per sender session the receiver keeps a watermark (everything up to it has been
handled) and the out-of-order messages above it (at most a window's worth). A message
at or below the watermark is a repeat: it is acknowledged again but not handled.
Messages are handled in sequence order, and every batch read from the socket is
answered with one cumulative ack per session. A handler that cannot take a message now
raises `NotHandled`: it is not acknowledged, and offered again when its sender repeats it.

Memory stays bounded: sessions unheard of for `session_ttl` seconds are forgotten (and
at most `max_sessions` are kept), and the ids of the last `id_memory` handled messages
catch a message repeated under a new session (e.g. resent with the same id by a
restarted sender). Across a restart of the receiver itself the delivery is at least
once: the state above lives in memory, so consumers stay idempotent by id or uuid.
"""

from __future__ import annotations

import threading
import time
from collections import OrderedDict
from collections.abc import Callable
from types import TracebackType

import zmq

from mrss.bus import direct, sockets, wire
from mrss.bus.endpoints import BusEndpoints
from mrss.bus.incarnations import Incarnations
from mrss.bus.publisher import Publisher
from mrss.errors import DecodeError
from mrss.messages import Envelope

log = sockets.log

# A message further than this above the watermark is dropped (the sender will repeat it).
MAX_AHEAD = 8192
_BATCH = 512


class _Session:
    """What one sender session has delivered: watermark plus out-of-order messages."""

    __slots__ = ("watermark", "waiting", "last_seen")

    def __init__(self, watermark: int, now: float) -> None:
        self.watermark = watermark
        self.waiting: dict[int, Envelope | None] = {}  # None: malformed, skipped in order
        self.last_seen = now


class NotHandled(Exception):
    """Raised by a handler that could not take a message now (its journal cannot be
    written, say): the message is not acknowledged, the sender repeats it, and it is
    offered to the handler again (with everything after it from that sender)."""


class ReliableReceiver:
    """Calls `handler(env)` once per message id sent on `channel`, on its own thread.

    The handler's exceptions are logged; the message still counts as handled (it is not
    run again) — except `NotHandled`, which leaves it unacknowledged, to be offered again
    when its sender repeats it. A message the incarnation rule refuses (a dead or unproven
    incarnation, a replay) is acknowledged and never handled (mrss/bus/incarnations.py).
    `handled` counts handler calls; `close()` stops the thread.
    """

    def __init__(
        self, endpoints: BusEndpoints, src: str, inc: int = 0, channel: str = "action", *,
        handler: Callable[[Envelope], object], session_ttl: float = 600.0,
        max_sessions: int = 4096, id_memory: int = 65536,
        context: sockets.Context | None = None, incarnations: Incarnations | None = None,
    ) -> None:
        self.channel = wire.check_channel(channel)
        self.src, self.inc = src, inc
        self._handler = handler
        self._session_ttl = session_ttl
        self._max_sessions = max_sessions
        self._id_memory = id_memory
        self._sessions: OrderedDict[bytes, _Session] = OrderedDict()
        self._recent_ids: OrderedDict[str, None] = OrderedDict()
        self._drops = sockets.DropLog(f"reliable receiver {channel!r}")
        self._incarnations = incarnations or Incarnations(f"reliable receiver {channel!r}")
        self._incarnations.adopt(endpoints.authority())  # a keyed bus: proven ones only
        self.handled = 0
        self.held_back = 0  # NotHandled answers: messages left for their sender to repeat
        self._held_logged = 0.0
        ctx = sockets.context(context)
        self._sub, self._member = direct.subscriber_socket(ctx, endpoints,
                                                           [wire.data_topic(channel)])
        self._pub = Publisher(endpoints, src, inc, linger=0, context=ctx)
        self._closed = threading.Event()
        self._thread = threading.Thread(target=self._serve, daemon=True,
                                        name=f"mrss-reliable-rx-{channel}")
        self._thread.start()

    @property
    def sessions(self) -> int:
        """How many sender sessions are remembered (bounded by `max_sessions`)."""
        return len(self._sessions)

    @property
    def dropped(self) -> int:
        """How many malformed messages were dropped."""
        return self._drops.dropped

    @property
    def stale(self) -> int:
        """How many messages the incarnation rule refused (acknowledged, not handled)."""
        return self._incarnations.dropped

    def _serve(self) -> None:
        try:
            self._receive_until_closed()
        except Exception:
            log.exception("reliable receiver on channel %r failed", self.channel)
            raise
        finally:
            self._sub.close(0)
            direct.forget_member(self._member)
            self._pub.close()

    def _receive_until_closed(self) -> None:
        next_expiry = time.monotonic() + min(self._session_ttl, 60.0)
        while not self._closed.is_set():
            if not self._sub.poll(50, zmq.POLLIN):
                continue
            now = time.monotonic()
            touched: dict[bytes, _Session] = {}
            for _ in range(_BATCH):
                try:
                    frames = self._sub.recv_multipart(zmq.NOBLOCK)
                except zmq.Again:
                    break
                self._take(frames, now, touched)
            for session, state in touched.items():
                self._pub.send_frames((wire.ack_topic(self.channel, session),
                                       wire.pack_ack(session, state.watermark)))
            if now >= next_expiry:
                self._expire_sessions(now)
                next_expiry = now + min(self._session_ttl, 60.0)

    def _take(self, frames: list[bytes], now: float, touched: dict[bytes, _Session]) -> None:
        if wire.is_answer(frames):
            return
        try:
            if len(frames) != 4:
                raise DecodeError(f"reliable message of {len(frames)} frame(s), not 4",
                                  topic=frames[0].decode("utf-8", "replace"))
            session, seq, base = wire.unpack_header(frames[3])
        except DecodeError as exc:
            self._drops.drop(exc)
            return
        state = self._session(session, base, now)
        touched[session] = state
        if base - 1 > state.watermark:
            # Another receiver on this channel acknowledged these; they are not ours.
            for old in [s for s in state.waiting if s < base]:
                del state.waiting[old]
            state.watermark = base - 1
        if seq <= state.watermark:
            return  # a repeat: acknowledged again below, never handled twice
        if seq in state.waiting:  # held back (NotHandled) or out of order: try again
            self._deliver_in_order(state)
            return
        if seq - state.watermark > MAX_AHEAD:
            return
        try:
            state.waiting[seq] = wire.decode_frames(frames)
        except DecodeError as exc:
            self._drops.drop(exc)
            state.waiting[seq] = None
        self._deliver_in_order(state)

    def _session(self, session: bytes, base: int, now: float) -> _Session:
        state = self._sessions.get(session)
        if state is None:
            state = self._sessions[session] = _Session(base - 1, now)
            while len(self._sessions) > self._max_sessions:
                self._sessions.popitem(last=False)
        else:
            self._sessions.move_to_end(session)
            state.last_seen = now
        return state

    def _deliver_in_order(self, state: _Session) -> None:
        while state.watermark + 1 in state.waiting:
            env = state.waiting[state.watermark + 1]
            if env is not None and env.id not in self._recent_ids \
                    and self._incarnations.admit(env):
                try:
                    self._handler(env)
                except NotHandled as exc:  # not acknowledged: offered again on a repeat
                    self.held_back += 1
                    now = time.monotonic()
                    if now - self._held_logged >= 1.0:  # at most a line a second
                        self._held_logged = now
                        log.warning("channel %r: message %s held back (%d so far): %s",
                                    self.channel, env.id, self.held_back, exc)
                    return
                except Exception:
                    log.exception("channel %r: handler failed on message %s", self.channel,
                                  env.id)
                self.handled += 1
                self._recent_ids[env.id] = None
                if len(self._recent_ids) > self._id_memory:
                    self._recent_ids.popitem(last=False)
            state.watermark += 1
            del state.waiting[state.watermark]

    def _expire_sessions(self, now: float) -> None:
        while self._sessions:
            session, state = next(iter(self._sessions.items()))
            if now - state.last_seen < self._session_ttl:
                break
            del self._sessions[session]

    def close(self) -> None:
        """Stop handling messages and close the sockets."""
        if self._closed.is_set():
            return
        self._closed.set()
        if self._thread is not threading.current_thread():
            self._thread.join(timeout=5)

    def __enter__(self) -> ReliableReceiver:
        return self

    def __exit__(self, exc_type: type[BaseException] | None, exc: BaseException | None,
                 tb: TracebackType | None) -> None:
        self.close()
