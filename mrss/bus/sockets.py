"""ZeroMQ socket set-up shared by the bus parts, and the log of dropped messages."""

from __future__ import annotations

import logging
import time

import zmq

from mrss.errors import DecodeError

log = logging.getLogger("mrss.bus")

Socket = zmq.Socket[bytes]
Context = zmq.Context[Socket]

# Queue limit per peer, in ZeroMQ messages (a publisher's batch is one). ZeroMQ's default
# (1000) drops bursts the reliable channel's window alone can fill; 10,000 plain
# messages are a few MB, full batches (16 kB) at most 160 MB for a stalled subscriber.
DEFAULT_HWM = 10_000
# Reconnect quickly after a proxy restart, without hammering a proxy that stays down.
RECONNECT_IVL_MS = 50
RECONNECT_IVL_MAX_MS = 500


def context(ctx: Context | None = None) -> Context:
    """The given context, or the process-wide one."""
    return ctx if ctx is not None else zmq.Context.instance()


def connect(
    ctx: Context, kind: int, endpoint: str, *, hwm: int = DEFAULT_HWM, linger_ms: int = 0,
) -> Socket:
    """A socket of `kind` connected to `endpoint`, reconnecting on its own when it drops."""
    sock = connecting(ctx, kind, hwm=hwm, linger_ms=linger_ms)
    try:
        sock.connect(endpoint)
    except zmq.ZMQError:
        sock.close(0)
        raise
    return sock


def connecting(ctx: Context, kind: int, *, hwm: int = DEFAULT_HWM, linger_ms: int = 0
               ) -> Socket:
    """A socket of `kind` set up to connect (queues, linger, reconnection), not yet
    connected: a direct publisher connects it to each member as it hears of them."""
    sock = ctx.socket(kind)
    sock.setsockopt(zmq.LINGER, linger_ms)
    sock.setsockopt(zmq.SNDHWM, hwm)
    sock.setsockopt(zmq.RCVHWM, hwm)
    sock.setsockopt(zmq.RECONNECT_IVL, RECONNECT_IVL_MS)
    sock.setsockopt(zmq.RECONNECT_IVL_MAX, RECONNECT_IVL_MAX_MS)
    return sock


class DropLog:
    """Logs malformed messages with topic and reason, at most `per_second` lines a second.

    A peer spraying garbage must not drown the log; the count of all drops is kept.
    """

    def __init__(self, where: str, per_second: int = 10) -> None:
        self.where = where
        self.dropped = 0
        self._per_second = per_second
        self._window_start = 0.0
        self._in_window = 0
        self._suppressed = 0

    def drop(self, exc: DecodeError) -> None:
        self.dropped += 1
        now = time.monotonic()
        if now - self._window_start >= 1.0:
            if self._suppressed:
                log.warning("%s: %d more malformed message(s) dropped", self.where,
                            self._suppressed)
            self._window_start, self._in_window, self._suppressed = now, 0, 0
        if self._in_window < self._per_second:
            self._in_window += 1
            log.warning("%s: dropped malformed message on topic %r: %s", self.where,
                        exc.topic, exc.reason)
        else:
            self._suppressed += 1
