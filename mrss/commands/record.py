"""`mrss record`: write every message on a running system's bus to a file.

```
mrss record --run-dir DIR [--prefix P ...] [--out FILE] [--duration S]
            [--project NAME]
```

Records the messages the proxy delivers as an MCAP file (a channel per topic, each
message its envelope in JSON against its kind's schema, robots' positions also as
Foxglove LocationFix; layout in `mrss.recording.mcap_writer`), until SIGINT/SIGTERM or
`--duration` seconds, then prints how many it recorded and exits 0. `--project` keeps
the project's name, project.toml and AgentSpeak files in the recording.
Messages that do not decode as
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
from mrss.config.projects import PROJECT_FILE, project_path
from mrss.errors import MrssError
from mrss.recording.mcap_writer import McapRecordingWriter, ProjectFiles
from mrss.recording.recorder import GATHER, BusRecorder

EXIT_ERROR = 2


def configure(parser: argparse.ArgumentParser) -> None:
    add_bus_arguments(parser)
    parser.add_argument("--prefix", action="append", default=None, metavar="P",
                        help="record only topics starting with P (repeatable; default all)")
    parser.add_argument("--out", type=Path, default=None, metavar="FILE",
                        help="where to write (default mrss-YYYYmmdd-HHMMSS.mcap here)")
    parser.add_argument("--duration", type=positive_float, default=None, metavar="S",
                        help="stop after S seconds (default: at SIGINT/SIGTERM)")
    parser.add_argument("--project", default=None, metavar="NAME",
                        help="keep this project's project.toml and agent files in the "
                             "recording (a project name, or its folder)")


def project_files(name: str) -> ProjectFiles:
    """The project `--project` names: a folder holding project.toml, or a project name."""
    folder = Path(name)
    if not (folder / PROJECT_FILE).is_file():
        folder = project_path(name)
    try:
        return ProjectFiles.read(folder)
    except OSError as exc:
        raise MrssError(f"cannot read project {name!r}: {exc.strerror or exc}") from None


def run(args: argparse.Namespace) -> int:
    prefixes: list[str] = args.prefix if args.prefix else [""]
    out: Path = args.out or Path(time.strftime("mrss-%Y%m%d-%H%M%S.mcap"))
    stop = threading.Event()

    def on_signal(signum: int, frame: FrameType | None) -> None:
        stop.set()

    signal.signal(signal.SIGINT, on_signal)
    signal.signal(signal.SIGTERM, on_signal)
    try:
        project = project_files(args.project) if args.project else None
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
            writer = McapRecordingWriter(handle, created=time.time(),
                                         endpoints=endpoints.to_dict(), prefixes=prefixes,
                                         project=project)
            print(f"recording {endpoints.backend} to {out}", flush=True)
            deadline = None if args.duration is None else time.monotonic() + args.duration
            recorder.record(writer, stop, deadline, gather=GATHER)
            writer.finish()
    finally:
        recorder.close()
    print(f"recorded {writer.count} messages ({writer.malformed} malformed) to {out}",
          flush=True)
    return 0
