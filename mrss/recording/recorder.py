"""The recorder: every bus message a raw subscriber receives, frames untouched, to a file.

Behind `mrss record` and the dashboard's Ctrl+P "record the bus". The proxy's welcome and
reliable-channel acknowledgements are not bus traffic and are left out; a message that
does not decode is recorded with the reason (`fault_of`; a writer with `received`, the
MCAP writer, checks each message itself as it writes it, unpacking it once).
"""

from __future__ import annotations

import threading
import time
from collections.abc import Callable
from typing import Protocol

import zmq

from mrss.bus import BusEndpoints, direct, sockets
from mrss.bus.wire import (
    MEMBER,
    RELIABLE_PREFIX,
    WELCOME,
    WELCOME_DIRECT,
    is_ack,
    message_frames,
)
from mrss.errors import DecodeError
from mrss.messages import decode
from mrss.recording.format import RecordedMessage

_POLL_MS = 100
# The recorder's own queue, in ZeroMQ messages (a batch is one): ten times a component's,
# so a burst the writer is briefly behind on is not dropped at the proxy.
RECORDER_HWM = 100_000
_NOBLOCK = int(zmq.NOBLOCK)
# A file recorder drains its socket at most every GATHER seconds: woken for every few
# messages, it spent a quarter of its CPU on waking up (at 10,000 msgs/s, `mrss bench
# record`: 21 against 15.5 us a message). A tenth of a second of a 50,000/s bus is
# 5,000 messages, well within RECORDER_HWM; chunks are closed every second anyway.
# The live Foxglove bridge does not gather (its viewers see messages as they come).
GATHER = 0.1


class Writer(Protocol):
    """Where a recorder writes: the MCAP writer, the Foxglove bridge, the older format's.
    One that also has `received(t, frames)` is given the frames unchecked."""

    def write(self, message: RecordedMessage) -> None: ...

    def flush(self) -> None: ...


class BusRecorder:
    """A raw subscriber: hands every bus message, frames untouched, to a writer."""

    def __init__(self, endpoints: BusEndpoints, prefixes: list[str]) -> None:
        self._endpoints = endpoints
        self._topics = [WELCOME, *(p.encode() for p in prefixes)]
        sock, self._member = direct.subscriber_socket(
            sockets.context(), endpoints, self._topics, hwm=RECORDER_HWM)
        self._sock = sock

    def wait_connected(self, timeout: float, stop: threading.Event) -> bool:
        """Wait for the proxy's welcome; False on timeout or when `stop` is set."""
        deadline = time.monotonic() + timeout
        while not stop.is_set():
            remaining = deadline - time.monotonic()
            if remaining <= 0:
                return False
            wait_ms = max(1, min(_POLL_MS, int(remaining * 1000)))
            if not self._sock.poll(wait_ms, zmq.POLLIN):
                continue
            frames = self._sock.recv_multipart()
            if frames == [WELCOME_DIRECT] and self._member is None:
                # A direct bus we were not told of (--run-dir): join it, then be answered.
                self._member = direct.become_member(self._sock, self._endpoints, self._topics)
            elif frames == [WELCOME] or (self._member and frames[0][:1] == MEMBER):
                return True  # the proxy's welcome; on a direct bus its answer to us
        return False

    def record(self, writer: Writer, stop: threading.Event,
               deadline: float | None, gather: float = 0.0) -> None:
        """Record until `stop` is set or the monotonic `deadline` passes, then take what
        is already queued. With `gather` (seconds), the socket is drained at most that
        often (see `GATHER`)."""
        while not stop.is_set():
            woke = time.monotonic()
            wait_ms = _POLL_MS
            if deadline is not None:
                remaining = deadline - woke
                if remaining <= 0:
                    break
                wait_ms = max(1, min(wait_ms, int(remaining * 1000)))
            try:
                ready = self._sock.poll(wait_ms, zmq.POLLIN)
            except zmq.ZMQError:  # EINTR when a signal arrives
                continue
            if ready:
                self._drain(writer)
            writer.flush()  # what it decides to write out, a recorder killed now keeps
            if gather:  # the next drain, `gather` after this one began (not past deadline)
                until = woke + gather if deadline is None else min(woke + gather, deadline)
                stop.wait(until - time.monotonic())
        self._drain(writer)  # what came before the stop and is waiting (up to `gather`)

    def _drain(self, writer: Writer) -> None:
        received_by: Callable[[float, list[bytes]], None] | None = getattr(
            writer, "received", None)
        # pyzmq's recv_multipart asks the socket for RCVMORE after each frame, an option
        # lookup that took a sixth of the recorder's time (profiled); a frame knows it
        recv, clock = self._sock.recv, time.time
        while True:
            try:
                frame = recv(_NOBLOCK, copy=False)
                frames = [frame.bytes]
                while frame.more:
                    frame = recv(_NOBLOCK, copy=False)
                    frames.append(frame.bytes)
            except zmq.Again:
                return
            received = clock()
            first = frames[0]
            if (first == WELCOME and len(frames) == 1) or (
                    first.startswith(RELIABLE_PREFIX) and len(frames) == 2 and is_ack(first)):
                continue  # a proxy restart's greeting, a reliable ack: not traffic
            if received_by is not None:
                received_by(received, frames)
            else:
                writer.write(RecordedMessage(received, tuple(frames), fault_of(frames)))

    def close(self) -> None:
        self._sock.close(0)
        direct.forget_member(self._member)


def fault_of(frames: list[bytes]) -> str:
    """Why `frames` are not a valid bus message ("" if they are)."""
    try:
        for topic, payload in message_frames(frames):
            decode(topic, payload)
    except DecodeError as exc:
        return exc.reason
    return ""
