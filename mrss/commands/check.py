"""`mrss check PROJECT`: load and validate a project without starting anything.

Validates project.toml (every key; component classes are imported to be sure they
exist and subclass Component), then the project's own files (`check_parts`): agent.asl
compiled by the real interpreter (every syntax error as file:line:col with a caret),
events.py / datalayer.py / rcl.py / skills.py imported from the project folder with
their expected classes, and the robots' tables and link options. Nothing is started
and no robot is connected. Errors name the file and line (and the key); all of them
are printed and the exit code is 2. OK: a summary and exit 0.
"""

from __future__ import annotations

import argparse
import sys

from mrss.commands.check_parts import check_project_files
from mrss.config import ProjectConfig, load_project
from mrss.errors import ConfigError, SupervisionError
from mrss.supervision.component_main import load_class

EXIT_INVALID = 2


def configure(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("project", help="project name (projects/<name>/)")
    parser.add_argument("--no-import", action="store_true",
                        help="check project.toml only: import no class, read no project file")


def run(args: argparse.Namespace) -> int:
    try:
        config = load_project(args.project)
        if not args.no_import:
            check_classes(config)
    except ConfigError as exc:
        print(f"mrss check: {exc}", file=sys.stderr)
        return EXIT_INVALID
    found = None if args.no_import else check_project_files(config)
    for warning in [*config.warnings, *(found.warnings if found else [])]:
        print(f"warning: {warning}", file=sys.stderr)
    if found is not None and found.errors:
        for error in found.errors:
            print(f"mrss check: {error}", file=sys.stderr)
        print(f"mrss check: {config.name}: {len(found.errors)} error(s)", file=sys.stderr)
        return EXIT_INVALID
    print(summary(config))
    if found is not None:
        print("\n".join(found.summary))
        print(f"{config.name}: OK")
    return 0


def check_classes(config: ProjectConfig) -> None:
    """Import every enabled component's class; a failure is a ConfigError on its module key."""
    for comp in config.components:
        if not comp.enabled:
            continue
        try:
            load_class(comp.module, str(config.directory))
        except SupervisionError as exc:
            raise ConfigError(str(exc), file=str(config.file),
                              key=f"components.{comp.id}.module") from None


def summary(config: ProjectConfig) -> str:
    """A short human summary of the validated project."""
    s = config.supervisor
    spec = s.spec
    lines = [
        f"project {config.name}: {config.file}",
        f"  supervisor: {spec.strategy.value}, intensity {spec.intensity} in {spec.period:g}s, "
        f"backoff {spec.backoff.initial:g}s x{spec.backoff.factor:g} cap {spec.backoff.cap:g}s "
        f"jitter {spec.backoff.jitter:g}, on_exceeded {spec.on_exceeded.value}, "
        f"heartbeat {s.heartbeat_interval:g}s x{s.heartbeat_misses}, launcher {s.launcher}",
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
