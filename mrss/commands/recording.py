"""`mrss recording`: look into an MCAP recording made by `mrss record`.

```
mrss recording info FILE
mrss recording export FILE [--topic PREFIX] [--format csv|jsonl] [--out FILE]
mrss recording report FILE [--format text|json]
```

`info` prints the project, the MRSS version that recorded it, its time span, each
channel (topic, schema, message count), the incarnations seen and the attachments.
`export` writes the messages on topics starting with PREFIX (default: all), for
spreadsheets (`csv`: a column per field, nested maps as dotted names) or notebooks
(`jsonl`: a JSON object a line with topic, log_time, publish_time and the message), to
`--out` or stdout. `report` prints the mission's figures (mrss/recording/mission_figures.py):
per goal the time from its report to the first action and to done, actions per robot
and outcome, restarts and faults, robot losses and reassignments, operator
interventions per hour, and the share of goals done without an operator.

Exit 0; 2 when FILE cannot be read, is not an MRSS MCAP recording (e.g. another tool's
MCAP, an older-format `.mrssrec`: `mrss replay` plays those), or is cut or damaged:
then what comes before the damage is shown or exported first, and the error gives the
byte offset where it starts.
"""

from __future__ import annotations

import argparse
import contextlib
import enum
import json
import sys
import time
from collections.abc import Iterator
from pathlib import Path
from typing import IO

from mrss.recording.contents import Contents, contents, export_csv, export_jsonl
from mrss.recording.format import RecordingError
from mrss.recording.mcap_reader import McapRecording
from mrss.recording.mission_report import MissionReport, as_dict, to_text

EXIT_ERROR = 2


class ExportFormat(enum.StrEnum):
    CSV = "csv"
    JSONL = "jsonl"


class ReportFormat(enum.StrEnum):
    TEXT = "text"
    JSON = "json"


def configure(parser: argparse.ArgumentParser) -> None:
    actions = parser.add_subparsers(dest="action", required=True, metavar="ACTION")
    info = actions.add_parser("info", help="channels, counts, time span, project")
    info.add_argument("file", type=Path, help="an MCAP recording made by `mrss record`")
    export = actions.add_parser("export", help="messages of some topics as csv or jsonl")
    export.add_argument("file", type=Path, help="an MCAP recording made by `mrss record`")
    export.add_argument("--topic", default="", metavar="PREFIX",
                        help="only topics starting with PREFIX (default: all)")
    export.add_argument("--format", type=ExportFormat, choices=list(ExportFormat),
                        default=ExportFormat.JSONL, help="csv or jsonl (default jsonl)")
    export.add_argument("--out", type=Path, default=None, metavar="FILE",
                        help="where to write (default: stdout)")
    report = actions.add_parser("report", help="mission figures: goals, actions, restarts, "
                                               "losses, operator interventions")
    report.add_argument("file", type=Path, help="an MCAP recording made by `mrss record`")
    report.add_argument("--format", type=ReportFormat, choices=list(ReportFormat),
                        default=ReportFormat.TEXT, help="text (Markdown) or json")


def run(args: argparse.Namespace) -> int:
    path: Path = args.file
    try:
        with path.open("rb") as source:
            if args.action == "info":
                return _info(path, contents(source))
            if args.action == "report":
                return _report(path, MissionReport(source), args.format)
            return _export(args, source)
    except OSError as exc:
        print(f"mrss recording: cannot read {exc.filename or path}: {exc.strerror or exc}",
              file=sys.stderr)
    except RecordingError as exc:
        print(f"mrss recording: {path}: {exc}", file=sys.stderr)
    return EXIT_ERROR


def _when(ns: int | None) -> str:
    if ns is None:
        return "-"
    stamp = time.strftime("%Y-%m-%d %H:%M:%S", time.localtime(ns / 1e9))
    return f"{stamp}.{int(ns % 1_000_000_000 / 1e6):03d}"


def _info(path: Path, found: Contents) -> int:
    mrss_meta = found.metadata.get("mrss", {})
    project = found.metadata.get("project", {})
    span = (found.last - found.first) / 1e9 if found.first is not None and found.last else 0.0
    print(f"file:      {path}")
    print(f"project:   {project.get('name', '(not recorded: mrss record --project NAME)')}")
    print(f"recorded:  by MRSS {mrss_meta.get('version', '?')} ({found.library})")
    print(f"span:      {_when(found.first)} .. {_when(found.last)} ({span:.3f} s)")
    print(f"messages:  {found.messages} on {len(found.channels)} channels")
    width = max((len(c.topic) for c in found.channels.values()), default=5)
    print(f"  {'topic':<{width}}  {'schema':<24}  {'count':>8}")
    for channel in sorted(found.channels.values(), key=lambda c: c.topic):
        print(f"  {channel.topic:<{width}}  {channel.schema:<24}  {channel.count:>8}")
    incarnations = found.metadata.get("incarnations")
    if incarnations is not None:
        print("incarnations: " + (", ".join(f"{src} {incs}" for src, incs in
                                            incarnations.items()) or "-"))
    if found.attachments:
        print(f"attachments: {', '.join(found.attachments)}")
    if found.damage is not None:
        print(f"mrss recording: {path}: {found.damage} (the above is what comes before it)",
              file=sys.stderr)
        return EXIT_ERROR
    return 0


def _report(path: Path, report: MissionReport, form: ReportFormat) -> int:
    data = as_dict(report.figures)
    if form is ReportFormat.JSON:
        print(json.dumps({"file": str(path), "project": report.project,
                          "warnings": report.warnings, **data}, indent=2))
    else:
        print(f"# Mission report: {report.project or path.name}\n")
        print(to_text(report.figures, data))
    for warning in report.warnings:
        print(f"mrss recording: {path}: {warning}", file=sys.stderr)
    if report.damage is not None:
        print(f"mrss recording: {path}: {report.damage} (the figures are of what comes "
              "before it)", file=sys.stderr)
        return EXIT_ERROR
    return 0


@contextlib.contextmanager
def _output(out: Path | None) -> Iterator[IO[str]]:
    if out is None:
        yield sys.stdout
        sys.stdout.flush()
    else:
        with out.open("w", encoding="utf-8", newline="") as handle:
            yield handle


def _export(args: argparse.Namespace, source: IO[bytes]) -> int:
    McapRecording(source)  # not MRSS MCAP: refused before anything is written
    source.seek(0)
    with _output(args.out) as out:
        if args.format is ExportFormat.CSV:
            count = export_csv(source, args.topic, out)
        else:
            count = export_jsonl(McapRecording(source), args.topic, out)
    print(f"exported {count} messages", file=sys.stderr)
    return 0
