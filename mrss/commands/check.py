"""`mrss check PROJECT`: load and validate a project without starting anything.

For now this validates project.toml (every key; component classes are imported to be
sure they exist and subclass Component) and prints a summary. Errors name the file, the
line when it can be found, and the key, and exit 2.
"""

from __future__ import annotations

import argparse
import sys

from mrss.config import ProjectConfig, load_project
from mrss.errors import ConfigError, SupervisionError
from mrss.supervision.component_main import load_class

EXIT_INVALID = 2


def configure(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("project", help="project name (projects/<name>/)")
    parser.add_argument("--no-import", action="store_true",
                        help="do not import component classes (syntax and schema only)")


def run(args: argparse.Namespace) -> int:
    try:
        config = load_project(args.project)
        if not args.no_import:
            check_classes(config)
    except ConfigError as exc:
        print(f"mrss check: {exc}", file=sys.stderr)
        return EXIT_INVALID
    for warning in config.warnings:
        print(f"warning: {warning}", file=sys.stderr)
    print(summary(config))
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
