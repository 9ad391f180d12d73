"""`mrss check PROJECT`: prove a project consistent without starting anything.

project.toml is loaded and validated (`mrss.config.loader`), then every check of `mrss.check`
runs on it: options declared and valid, agent actions with recipes, recipes with skills,
skills with the right hooks, queries the data layer answers, percepts the agent handles.
Every error is printed as `file:line:col: message` and the exit code is 2; warnings are
printed and do not change it. `--json` prints the findings as one JSON object for
editors and CI (same exit codes). OK: a summary and exit 0.
`mrss supervise` runs the same checks first (`verify`, or `verify_file` in its fork
server) and refuses to start a project with an error.
"""

from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path

from mrss.check import Report, check_project, passed
from mrss.config.loader import load_file, load_project
from mrss.config.project import ProjectConfig
from mrss.errors import ConfigError
from mrss.supervision.spec import OnExceeded

EXIT_INVALID = 2


def configure(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("project", help="project name (projects/<name>/)")
    parser.add_argument("--no-import", action="store_true",
                        help="check project.toml only: import no class, read no project file")
    parser.add_argument("--json", action="store_true",
                        help="print the findings as JSON (for editors and CI)")


def run(args: argparse.Namespace) -> int:
    try:
        config = load_project(args.project)
    except ConfigError as exc:
        if args.json:
            file, _, line = (exc.file or "").rpartition(":")  # "path:line" names the line
            if not line.isdigit():
                file, line = exc.file or "", "0"
            print(json.dumps({"project": args.project, "ok": False, "findings": [
                {"file": file, "line": int(line), "col": 0, "message": exc.reason,
                 "severity": "error", "check": "config", "key": exc.key, "detail": ""}]}))
        else:
            print(f"mrss check: {exc}", file=sys.stderr)
        return EXIT_INVALID
    if args.no_import:
        print(summary(config))
        return 0
    report = check_project(config)
    if args.json:
        print(json.dumps(report.as_json(), indent=2))
        return EXIT_INVALID if report.errors else 0
    print_findings(report)
    if report.errors:
        return EXIT_INVALID
    print(summary(config))
    print("\n".join(report.summary))
    print(f"{config.name}: OK")
    return 0


def print_findings(report: Report) -> None:
    for finding in report.warnings:
        print(finding.text(), file=sys.stderr)
    for finding in report.errors:
        print(f"mrss check: {finding.text()}", file=sys.stderr)
    if report.errors:
        print(f"mrss check: {report.project}: {len(report.errors)} error(s)", file=sys.stderr)


def verify_file(path: str) -> bool:
    """`verify` a project.toml (for the fork server, which checks before `mrss supervise`
    starts anything); a project that does not load is reported too."""
    try:
        config = load_file(Path(path))
    except ConfigError as exc:
        print(f"mrss supervise: {exc}", file=sys.stderr)
        return False
    report = check_project(config)
    print_findings(report)
    if not report.errors and not report.warnings and "nodes" not in config.sections:
        passed.remember(config.directory)  # the next start of it as it is skips this
    return not report.errors


def verify(config: ProjectConfig) -> bool:
    """Run every check before a start; print the findings; False when there is an error."""
    report = check_project(config)
    print_findings(report)
    return not report.errors


def summary(config: ProjectConfig) -> str:
    """A short human summary of the validated project."""
    s = config.supervisor
    spec = s.spec
    give_up = "stop_system" if spec.on_exceeded is OnExceeded.ESCALATE else \
        f"stop_component, retry after {spec.probation:g}s"
    groups = "".join(f"; group {g.name}: {', '.join(g.children)}" for g in spec.groups)
    lines = [
        f"project {config.name}: {config.file}",
        f"  supervisor: {spec.strategy.value}, intensity {spec.intensity} in {spec.period:g}s "
        f"per component, backoff {spec.backoff.initial:g}s x{spec.backoff.factor:g} cap "
        f"{spec.backoff.cap:g}s jitter {spec.backoff.jitter:g}, on_give_up {give_up}, "
        f"heartbeat {s.heartbeat_interval:g}s x{s.heartbeat_misses}, launcher {s.launcher}"
        f"{groups}",
        f"  components ({sum(c.enabled for c in config.components)} enabled):",
    ]
    for c in config.components:
        flag = "" if c.enabled else "  (disabled)"
        shutdown = c.shutdown if c.shutdown == "kill" else f"{c.shutdown:g}s"
        opts = f"  options {sorted(c.options)}" if c.options else ""
        lines.append(f"    {c.id:<16} {c.module}  {c.restart.value}, shutdown {shutdown}, "
                     f"start_timeout {c.start_timeout:g}s{opts}{flag}")
    if config.sections:
        lines.append(f"  other tables: {', '.join(sorted(config.sections))}")
    return "\n".join(lines)
