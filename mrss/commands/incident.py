"""`mrss incident export RUN_OR_PROJECT`: a run's incident record as a report or rows.

```
mrss incident export RUN_OR_PROJECT [--format md|html|jsonl|csv] [--out FILE]
```

RUN_OR_PROJECT is a run dir (the one holding `incident.jsonl`), the file itself, or a
project whose `[supervisor] run_dir` is kept. `md` and `html` are a readable report
(a summary and the timeline), `jsonl` and `csv` the rows for tools.

Exit 0; 2 when there is no record or it cannot be read; 1 when some lines are damaged:
every good row is still exported, and each damaged line is named on stderr with its
line number and byte offset.
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

from mrss.config.loader import load_project
from mrss.errors import ConfigError
from mrss.incident.export import ExportFormat, render
from mrss.incident.journal import FILE_NAME, incident_file, read_incident

EXIT_DAMAGED = 1
EXIT_ERROR = 2


def configure(parser: argparse.ArgumentParser) -> None:
    actions = parser.add_subparsers(dest="action", required=True, metavar="ACTION")
    export = actions.add_parser("export", help="the record as md, html, jsonl or csv")
    export.add_argument("source", type=Path, metavar="RUN_OR_PROJECT",
                        help=f"a run dir (with {FILE_NAME}), the file, or a project with "
                             "[supervisor] run_dir")
    export.add_argument("--format", type=ExportFormat, choices=list(ExportFormat),
                        default=ExportFormat.MD, help="md (default), html, jsonl or csv")
    export.add_argument("--out", type=Path, default=None, help="write here, not stdout")


def locate(source: Path) -> Path:
    """The incident file `source` means; FileNotFoundError saying what was looked at."""
    if source.is_file():
        if source.name == "project.toml":
            source = source.parent
        else:
            return source
    if incident_file(source).exists():
        return incident_file(source)
    if (source / "project.toml").exists():
        config = load_project(str(source))
        if not config.supervisor.run_dir:
            raise FileNotFoundError(f"{source}: the project keeps no run dir ([supervisor] "
                                    "run_dir): name the run dir `mrss supervise --run-dir` "
                                    "used")
        path = incident_file(config.directory / config.supervisor.run_dir)
        if path.exists():
            return path
        raise FileNotFoundError(f"{path}: no incident record (has the project run?)")
    raise FileNotFoundError(f"{source}: neither a run dir with {FILE_NAME} nor a project")


def run(args: argparse.Namespace) -> int:
    try:
        path = locate(args.source)
        entries, problems = read_incident(path)
    except (OSError, ConfigError) as exc:
        print(f"mrss incident: {exc}", file=sys.stderr)
        return EXIT_ERROR
    text = render(args.format, str(path.parent.name), entries, problems)
    if args.out is None:
        sys.stdout.write(text)
    else:
        args.out.write_text(text, encoding="utf-8")
    for problem in problems:
        print(f"mrss incident: damaged line left out: {problem}", file=sys.stderr)
    return EXIT_DAMAGED if problems else 0
