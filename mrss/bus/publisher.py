"""Publishing messages on the bus: encode, then send through the proxy's frontend."""

from __future__ import annotations

import threading
import time
from collections import deque
from types import TracebackType

import zmq

from mrss.bus import sockets
from mrss.bus.endpoints import BusEndpoints
from mrss.errors import BusError
from mrss.messages import IdGenerator, Message, encode

# Subscription notices from the proxy queue up on our XPUB socket; read them now and then.
_DRAIN_EVERY = 512
_SNDMORE = int(zmq.SNDMORE)


class Publisher:
    """Sends messages to every subscriber of their topic; thread-safe.

    Plain publish/subscribe: a message sent while the proxy is down or restarting is
    queued (up to `hwm`) and sent on reconnect, but may be lost around a crash. Use the
    reliable channel where a loss matters. Messages published before the proxy first
    subscribed to this publisher are held (up to `hwm`) and sent once it has, by a
    short-lived joiner thread, so a component's first words are not lost.

    The socket is an XPUB connected to the proxy's XSUB, so the publisher can tell when
    the proxy has subscribed to it (`wait_connected`): a short-lived sender such as
    `mrss send` waits for that before its one message.
    """

    def __init__(
        self, endpoints: BusEndpoints, src: str, inc: int = 0, *,
        hwm: int = sockets.DEFAULT_HWM, linger: float = 1.0,
        context: sockets.Context | None = None,
    ) -> None:
        self.src = src
        self.inc = inc
        self.endpoints = endpoints
        self._ids = IdGenerator()
        self._lock = threading.Lock()
        self._sock: sockets.Socket | None = sockets.connect(
            sockets.context(context), zmq.XPUB, endpoints.frontend, hwm=hwm,
            linger_ms=int(linger * 1000))
        self._connected = False
        self._sent = 0
        self._held: deque[tuple[bytes, ...]] = deque(maxlen=hwm)
        self._joiner: threading.Thread | None = None

    def publish(self, msg: Message, topic: str | None = None) -> str:
        """Send `msg` on `topic` (default: the message's own topic); return its id."""
        msg_id = self._ids()
        topic_frame, payload = encode(msg, src=self.src, inc=self.inc, msg_id=msg_id,
                                      topic=topic)
        with self._lock:
            sock = self._sock
            if sock is None:
                raise BusError("publisher is closed")
            if not self._connected and self._hold((topic_frame, payload), sock):
                return msg_id
            # Two plain sends cost half of one send_multipart.
            sock.send(topic_frame, _SNDMORE)
            sock.send(payload)
            self._sent += 1
            if self._sent % _DRAIN_EVERY == 0:
                self._drain_subscriptions(sock)
        return msg_id

    def send_frames(self, frames: tuple[bytes, ...] | list[bytes]) -> None:
        """Send an already encoded multipart message (for relays and the reliable channel)."""
        with self._lock:
            sock = self._socket()
            if not self._connected and self._hold(tuple(frames), sock):
                return
            last = len(frames) - 1
            for i, frame in enumerate(frames):
                sock.send(frame, _SNDMORE if i < last else 0)
            self._sent += 1
            if self._sent % _DRAIN_EVERY == 0:
                self._drain_subscriptions(sock)

    def wait_connected(self, timeout: float = 5.0) -> bool:
        """Wait until the proxy has subscribed to this publisher; False on timeout."""
        deadline = time.monotonic() + timeout
        while True:
            with self._lock:
                sock = self._socket()
                self._drain_subscriptions(sock)
                if self._connected:
                    return True
                remaining = deadline - time.monotonic()
                if remaining <= 0:
                    return False
                sock.poll(int(min(remaining, 0.05) * 1000), zmq.POLLIN)

    def _drain_subscriptions(self, sock: sockets.Socket) -> None:
        while True:
            try:
                notice = sock.recv(zmq.NOBLOCK)
            except zmq.Again:
                return
            if notice[:1] == b"\x01":
                self._connected = True

    def _hold(self, frames: tuple[bytes, ...], sock: sockets.Socket) -> bool:
        """Hold `frames` while the proxy has not subscribed yet (lock held); False if it has."""
        self._drain_subscriptions(sock)
        if self._connected and not self._held:
            return False
        self._held.append(frames)
        if self._connected:
            self._send_held(sock)
        elif self._joiner is None:
            self._joiner = threading.Thread(target=self._join, name=f"{self.src}-pub-join",
                                            daemon=True)
            self._joiner.start()
        return True

    def _send_held(self, sock: sockets.Socket) -> None:
        while self._held:
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
                    if self._sock is not None:
                        self._send_held(self._sock)
                    self._joiner = None
                return

    def _socket(self) -> sockets.Socket:
        if self._sock is None:
            raise BusError("publisher is closed")
        return self._sock

    def close(self) -> None:
        """Close the socket; queued messages get up to `linger` seconds to go out."""
        with self._lock:
            if self._sock is not None:
                self._sock.close()
                self._sock = None

    def __enter__(self) -> Publisher:
        return self

    def __exit__(self, exc_type: type[BaseException] | None, exc: BaseException | None,
                 tb: TracebackType | None) -> None:
        self.close()
