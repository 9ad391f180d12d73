"""`mrss replay FILE`: publish a recording (see `mrss record`) on a running system's bus.

FILE is an MCAP recording or one of the older MRSS format (`.mrssrec`); both are read.

```
mrss replay FILE --to-bus --run-dir DIR [--speed X | --as-fast-as-possible] [--max-gap S]
                 [--prefix P ...] [--include-malformed]
mrss replay FILE --agent EDITED.asl [--reasoner ID]       # what if: no bus (replay_agent.py)
```

`--to-bus` says where the recording goes: onto a running system's bus (to look at a
recording in the dashboard instead: `mrss tui --replay FILE`). Without it, the former
spelling, it is replayed onto the bus as before, with a warning that shows the new one.

Messages go out in file order with their recorded spacing divided by `--speed`
(or back to back with `--as-fast-as-possible`), frames as recorded. Recorded times are
not trusted: `--speed` outside [0.001, 1000] is rejected, a gap longer than `--max-gap`
seconds (default 60, at most 3600) is replayed as that many, a time going backwards as
no gap, and an entry whose time is not a finite number >= 0 is skipped as undecodable.
Envelopes keep
their original id, time, sender and incarnation, and are marked as replayed
(`replayed: true`): components never take them for live state or robot data (they are
refused and counted, docs/bus.md); observers such as the dashboard and `mrss record` see
them as replayed. A reliable-channel message is
published as the plain message it carries (monitors see it; no reliable receiver
takes it for a live sender's), so a replay never drives robots through the action
channel. Messages recorded as malformed are skipped unless `--include-malformed`
(then sent as recorded, e.g. to test how components take garbage); undecodable entries
are skipped. Both are reported on stderr with their offset.

Exit 0 when all was replayed; 2 when the file is not a recording, or is truncated or
corrupt (after replaying every message before the damage; the error gives its offset),
or when no bus proxy answers within `--timeout`.
"""

from __future__ import annotations

import argparse
import sys
import time
from collections.abc import Callable, Iterable
from pathlib import Path

from mrss.bus import Publisher
from mrss.bus.wire import RELIABLE_PREFIX
from mrss.commands import replay_agent
from mrss.commands.busargs import (
    add_bus_arguments,
    connected_publisher,
    endpoints_from_args,
    number_in,
)
from mrss.errors import MrssError
from mrss.messages import mark_replayed
from mrss.recording.files import recorded_messages
from mrss.recording.format import RecordedMessage, RecordingError

EXIT_ERROR = 2
EXIT_INTERRUPTED = 130
MIN_SPEED, MAX_SPEED = 1e-3, 1e3
DEFAULT_MAX_GAP = 60.0
MAX_GAP_LIMIT = 3600.0


def configure(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("file", type=Path, help="a recording made by `mrss record`")
    parser.add_argument("--to-bus", action="store_true",
                        help="publish the recording on a running system's bus (--run-dir "
                             "or --endpoints)")
    add_bus_arguments(parser)
    pace = parser.add_mutually_exclusive_group()
    pace.add_argument("--speed", type=number_in(MIN_SPEED, MAX_SPEED, "the replay speed"),
                      default=1.0, metavar="X",
                      help=f"play X times as fast as recorded (default 1; {MIN_SPEED:g} to "
                           f"{MAX_SPEED:g})")
    parser.add_argument("--max-gap", type=number_in(0.0, MAX_GAP_LIMIT, "seconds"),
                        default=DEFAULT_MAX_GAP, metavar="S",
                        help=f"a longer pause between two recorded messages is replayed as "
                             f"S seconds (default {DEFAULT_MAX_GAP:g})")
    pace.add_argument("--as-fast-as-possible", action="store_true",
                      help="ignore the recorded timing")
    parser.add_argument("--prefix", action="append", default=None, metavar="P",
                        help="replay only topics starting with P (repeatable; default all)")
    parser.add_argument("--include-malformed", action="store_true",
                        help="also send messages recorded as malformed, as recorded")
    parser.add_argument("--agent", type=Path, default=None, metavar="EDITED.asl",
                        help="no bus: what if the recorded reasoner had run EDITED.asl? "
                             "(mrss/commands/replay_agent.py)")
    parser.add_argument("--reasoner", default="reasoner", metavar="ID",
                        help="with --agent: the reasoner's component id in the recording")


def run(args: argparse.Namespace) -> int:
    if args.agent is not None:
        return replay_agent.run(args)
    path: Path = args.file
    if not args.to_bus:
        print(f"mrss replay: warning: replaying onto the bus without --to-bus is the former "
              f"spelling; say: mrss replay {path} --to-bus ...", file=sys.stderr)
    skipped = _Skips()
    try:
        with path.open("rb") as handle:
            reader = recorded_messages(handle, on_skip=skipped.undecodable)
            endpoints = endpoints_from_args(args)
            with connected_publisher(endpoints, "mrss-replay", args.timeout) as publisher:
                player = Player(publisher,
                                speed=None if args.as_fast_as_possible else args.speed,
                                max_gap=args.max_gap,
                                prefixes=args.prefix, include_malformed=args.include_malformed,
                                on_malformed=skipped.malformed)
                code = _play(player, reader, path)
            # Leaving the block waited until every message had gone to the proxy.
    except OSError as exc:
        print(f"mrss replay: cannot read {path}: {exc.strerror or exc}", file=sys.stderr)
        return EXIT_ERROR
    except RecordingError as exc:
        print(f"mrss replay: {path}: {exc}", file=sys.stderr)
        return EXIT_ERROR
    except MrssError as exc:
        print(f"mrss replay: {exc}", file=sys.stderr)
        return EXIT_ERROR
    print(f"replayed {player.sent} messages from {path} (skipped {skipped.malformed_count} "
          f"malformed, {skipped.undecodable_count} undecodable)", flush=True)
    return code


def _play(player: Player, reader: Iterable[RecordedMessage], path: Path) -> int:
    """Play `reader` to its end; the exit code (damage in the file is reported here)."""
    try:
        player.play(reader)
    except RecordingError as exc:
        print(f"mrss replay: {path}: {exc} ({player.sent} messages before it were replayed)",
              file=sys.stderr)
        return EXIT_ERROR
    except KeyboardInterrupt:
        return EXIT_INTERRUPTED
    return 0


class _Skips:
    """Reports skipped entries on stderr and counts them."""

    def __init__(self) -> None:
        self.malformed_count = 0
        self.undecodable_count = 0

    def malformed(self, message: RecordedMessage) -> None:
        self.malformed_count += 1
        print(f"mrss replay: skipped malformed message at offset {message.offset}: "
              f"{message.note}", file=sys.stderr)

    def undecodable(self, offset: int, reason: str) -> None:
        self.undecodable_count += 1
        print(f"mrss replay: skipped undecodable entry at offset {offset}: {reason}",
              file=sys.stderr)


class Player:
    """Publishes recorded messages with their recorded spacing scaled by 1/`speed`.

    `speed=None` sends them back to back. Recorded times are not trusted: a gap longer
    than `max_gap` seconds (a recorder paused, a clock stepped, a forged entry) is
    replayed as `max_gap`, and one going back in time as none. Each message is due a
    scaled gap after the one before it, against a monotonic clock, so delays do not add
    up over a long recording.
    """

    def __init__(self, publisher: Publisher, *, speed: float | None,
                 max_gap: float = DEFAULT_MAX_GAP,
                 prefixes: list[str] | None = None, include_malformed: bool = False,
                 on_malformed: Callable[[RecordedMessage], None] | None = None) -> None:
        if speed is not None and not MIN_SPEED <= speed <= MAX_SPEED:
            raise ValueError(f"speed {speed!r} is outside [{MIN_SPEED:g}, {MAX_SPEED:g}]")
        if not 0 <= max_gap <= MAX_GAP_LIMIT:
            raise ValueError(f"max_gap {max_gap!r} is outside [0, {MAX_GAP_LIMIT:g}]")
        self._publisher = publisher
        self._speed = speed
        self._max_gap = max_gap
        self._prefixes = tuple(p.encode() for p in prefixes) if prefixes else (b"",)
        self._include_malformed = include_malformed
        self._on_malformed = on_malformed
        self.sent = 0

    def play(self, messages: Iterable[RecordedMessage]) -> None:
        """Publish `messages` in order (a RecordingReader's errors pass through)."""
        last: tuple[float, float] | None = None  # (recorded time, due time) of the last sent
        for message in messages:
            if not topic_of(message).startswith(self._prefixes):
                continue
            if message.malformed and not self._include_malformed:
                if self._on_malformed is not None:
                    self._on_malformed(message)
                continue
            if self._speed is not None:
                if last is None:
                    due = time.monotonic()
                else:
                    gap = min(max(message.t - last[0], 0.0), self._max_gap)
                    due = last[1] + gap / self._speed
                last = (message.t, due)
                delay = due - time.monotonic()
                if delay > 0:
                    time.sleep(delay)
            self._publisher.send_frames(sendable_frames(message))
            self.sent += 1


def topic_of(message: RecordedMessage) -> bytes:
    """The topic of the message(s) in an entry: the inner one for reliable-channel data."""
    frames = message.frames
    if len(frames) == 4 and frames[0].startswith(RELIABLE_PREFIX):
        return frames[1]
    return frames[0]


def sendable_frames(message: RecordedMessage) -> list[bytes]:
    """The frames to publish: as recorded, but reliable data as its plain message, and
    every envelope marked as replayed."""
    frames = message.frames
    if not message.malformed and len(frames) == 4 and frames[0].startswith(RELIABLE_PREFIX):
        return [frames[1], mark_replayed(frames[2])]
    return [frames[0], *map(mark_replayed, frames[1:])]
