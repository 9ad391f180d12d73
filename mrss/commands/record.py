"""`mrss record`: write every message on a running system's bus to a file.

```
mrss record --run-dir DIR [--prefix P ...] [--out FILE] [--duration S]
```

Records the ZeroMQ messages the proxy delivers, exactly as received (frames and
receive time; format in `mrss.recording`), until SIGINT/SIGTERM or `--duration`
seconds, then prints how many it recorded and exits 0. Messages that do not decode as
bus messages are recorded too, with the reason, and counted as malformed. The proxy's
welcome and reliable-channel acknowledgements are not bus traffic and are left out.
No proxy within `--timeout` exits 2 without creating the file.
"""

from __future__ import annotations

import argparse
import signal
import sys
import threading
import time
from pathlib import Path
from types import FrameType

import zmq

from mrss.bus import BusEndpoints, direct, sockets
from mrss.bus.wire import MEMBER, WELCOME, WELCOME_DIRECT, is_ack, message_frames
from mrss.commands.busargs import (
    add_bus_arguments,
    endpoints_from_args,
    no_bus_error,
    positive_float,
)
from mrss.errors import DecodeError, MrssError
from mrss.messages import decode
from mrss.recording import RecordedMessage, RecordingWriter

EXIT_ERROR = 2
_POLL_MS = 100
# The recorder's own queue, in ZeroMQ messages (a batch is one): ten times a component's,
# so a burst the writer is briefly behind on is not dropped at the proxy.
RECORDER_HWM = 100_000
_NOBLOCK = int(zmq.NOBLOCK)


def configure(parser: argparse.ArgumentParser) -> None:
    add_bus_arguments(parser)
    parser.add_argument("--prefix", action="append", default=None, metavar="P",
                        help="record only topics starting with P (repeatable; default all)")
    parser.add_argument("--out", type=Path, default=None, metavar="FILE",
                        help="where to write (default mrss-YYYYmmdd-HHMMSS.mrssrec here)")
    parser.add_argument("--duration", type=positive_float, default=None, metavar="S",
                        help="stop after S seconds (default: at SIGINT/SIGTERM)")


def run(args: argparse.Namespace) -> int:
    prefixes: list[str] = args.prefix if args.prefix else [""]
    out: Path = args.out or Path(time.strftime("mrss-%Y%m%d-%H%M%S.mrssrec"))
    stop = threading.Event()

    def on_signal(signum: int, frame: FrameType | None) -> None:
        stop.set()

    signal.signal(signal.SIGINT, on_signal)
    signal.signal(signal.SIGTERM, on_signal)
    try:
        endpoints = endpoints_from_args(args)
        recorder = BusRecorder(endpoints, prefixes)
    except MrssError as exc:
        print(f"mrss record: {exc}", file=sys.stderr)
        return EXIT_ERROR
    try:
        if not recorder.wait_connected(args.timeout, stop):
            if stop.is_set():
                return 0
            print(f"mrss record: {no_bus_error(endpoints.backend, args.timeout)}",
                  file=sys.stderr)
            return EXIT_ERROR
        try:
            handle = out.open("wb")
        except OSError as exc:
            print(f"mrss record: cannot write {out}: {exc.strerror or exc}", file=sys.stderr)
            return EXIT_ERROR
        with handle:
            writer = RecordingWriter(handle, created=time.time(),
                                     endpoints=endpoints.to_dict(), prefixes=prefixes)
            print(f"recording {endpoints.backend} to {out}", flush=True)
            deadline = None if args.duration is None else time.monotonic() + args.duration
            recorder.record(writer, stop, deadline)
    finally:
        recorder.close()
    print(f"recorded {writer.count} messages ({writer.malformed} malformed) to {out}",
          flush=True)
    return 0


class BusRecorder:
    """A raw subscriber: hands every bus message, frames untouched, to a RecordingWriter."""

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

    def record(self, writer: RecordingWriter, stop: threading.Event,
               deadline: float | None) -> None:
        """Record until `stop` is set or the monotonic `deadline` passes."""
        while not stop.is_set():
            wait_ms = _POLL_MS
            if deadline is not None:
                remaining = deadline - time.monotonic()
                if remaining <= 0:
                    return
                wait_ms = max(1, min(wait_ms, int(remaining * 1000)))
            try:
                ready = self._sock.poll(wait_ms, zmq.POLLIN)
            except zmq.ZMQError:  # EINTR when a signal arrives
                continue
            if not ready:
                continue
            self._drain(writer)
            writer.flush()  # a recorder killed now loses nothing it has written

    def _drain(self, writer: RecordingWriter) -> None:
        while True:
            try:
                frames = self._sock.recv_multipart(_NOBLOCK)
            except zmq.Again:
                return
            received = time.time()
            if frames == [WELCOME] or (len(frames) == 2 and is_ack(frames[0])):
                continue  # a proxy restart's greeting, a reliable ack: not traffic
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
