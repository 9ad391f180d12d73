"""`mrss replay FILE --agent EDITED.asl`: what if the recorded mission's reasoner had run
EDITED.asl? (mrss/recording/whatif.py; no bus, no robots).

```
mrss replay FILE --agent EDITED.asl [--reasoner ID]
```

Feeds the recording's percepts and action outcomes, in recorded order and time, to the
edited program on virtual time, and prints where its decisions first differ from the
recorded ones (action, robot, arguments, time), then both runs' actions side by side
(`*` marks a row that differs). `--reasoner` is the reasoner's component id in the
recording (default `reasoner`): its queries' answers are replayed.

Exit 0 once compared; 2 when FILE is not a recording or is damaged (the comparison is of
what comes before the damage), or EDITED.asl does not parse (file:line:col).
"""

from __future__ import annotations

import argparse
import sys
from collections.abc import Iterator
from pathlib import Path

from mrss.agentspeak.errors import AslSyntaxError
from mrss.errors import DecodeError
from mrss.messages import Envelope, decode
from mrss.recording.files import recorded_messages
from mrss.recording.format import RecordedMessage, RecordingError
from mrss.recording.whatif import report, what_if
from mrss.recording.whatif_timeline import timeline

EXIT_ERROR = 2


def _envelopes(messages: Iterator[RecordedMessage], damage: list[RecordingError]
               ) -> Iterator[tuple[Envelope, float]]:
    try:
        for message in messages:
            if message.malformed or len(message.frames) != 2:
                continue
            try:
                yield decode(*message.frames), message.t
            except DecodeError:
                continue
    except RecordingError as exc:
        damage.append(exc)


def run(args: argparse.Namespace) -> int:
    path: Path = args.file
    program: Path = args.agent
    damage: list[RecordingError] = []
    try:
        if not program.is_file():
            print(f"mrss replay: cannot read {program}: no such file", file=sys.stderr)
            return EXIT_ERROR
        with path.open("rb") as handle:
            line = timeline(_envelopes(recorded_messages(handle), damage), args.reasoner)
        result = what_if(program, line)
    except OSError as exc:
        print(f"mrss replay: cannot read {exc.filename or path}: {exc.strerror or exc}",
              file=sys.stderr)
        return EXIT_ERROR
    except RecordingError as exc:
        print(f"mrss replay: {path}: {exc}", file=sys.stderr)
        return EXIT_ERROR
    except AslSyntaxError as exc:
        print(f"mrss replay: {exc}", file=sys.stderr)
        return EXIT_ERROR
    print(f"what if {program.name} had run the mission of {path.name} "
          f"({len(line.inputs)} inputs over {line.span:.1f} s):")
    print(report(result))
    if damage:
        print(f"mrss replay: {path}: {damage[0]} (compared what comes before it)",
              file=sys.stderr)
        return EXIT_ERROR
    return 0
