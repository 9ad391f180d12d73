"""`mrss record`: write every message on a running system's bus to a file.

```
mrss record --run-dir DIR [--prefix P ...] [--out FILE] [--duration S]
```

Records the ZeroMQ messages the proxy delivers, exactly as received (frames and
receive time; format in `mrss.recording.format`), until SIGINT/SIGTERM or `--duration`
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

from mrss.commands.busargs import (
    add_bus_arguments,
    endpoints_from_args,
    no_bus_error,
    positive_float,
)
from mrss.errors import MrssError
from mrss.recording.format import RecordingWriter
from mrss.recording.recorder import BusRecorder

EXIT_ERROR = 2


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
