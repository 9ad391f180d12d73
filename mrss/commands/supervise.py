"""`mrss supervise PROJECT`: run a project's components under the root supervisor.

Starts the enabled components in file order, each after the previous one is ready;
on SIGINT/SIGTERM stops them in reverse order within their shutdown limits and exits
0 (a second signal kills what is left at once). A component (or group) that uses up its
restart budget is stopped and reported (`sup.give_up`) while the rest keeps running, and
retried after `retry_after`; only with `[supervisor] on_give_up = "stop_system"` does the
root stop everything and exit 1 with a message naming the child and its last reason.
Bad config exits 2. While it runs, the root answers `ctl.tree` and executes `ctl.fault`
commands from the bus (`mrss.runtime.remote`, for the TUI). Its `sup.*` events go
through an `EventOutbox`, which holds them while the bus proxy is down.

The fork server starts first, imports the components while the root imports its own
modules (`mrss.commands.supervise_root`), and checks the project in a child of its own
(docs/supervision.md, "Start"); with the exec launcher or the dashboard the check runs
here.

Every record of the run (the root's and every component's) is written to stderr and to
`<run_dir>/mrss.log` in one line format (rotated by size, `[logs]`: `mrss.logfile`;
the root hands the settings to its tree in `$MRSS_LOG_ROTATION`), and those at INFO and
above go on the bus as `LogRecord`s on `log.<component>` (`mrss.logs`). In an
interactive terminal (stdin, stdout and stderr are TTYs) and without `--no-tui`, the
dashboard opens instead of the log lines (`mrss.commands.supervise_tui`); quitting it
stops the system.
"""

from __future__ import annotations

import argparse
import logging
import os
import shutil
import signal
import sys
import tempfile
from pathlib import Path

from mrss import logfile, logs
from mrss.check import passed
from mrss.config.loader import load_project
from mrss.config.nodes import keys_dir, node_plan, root_children
from mrss.config.project import ProjectConfig
from mrss.errors import ConfigError, SupervisionError
from mrss.supervision.events import NODE_ENV
from mrss.supervision.launchers import ForkLauncher, preload_modules

EXIT_GAVE_UP = 1  # mrss.commands.supervise_root
EXIT_CONFIG = 2
CHECK = "mrss.commands.check:verify_file"  # what the fork server runs before a start


def configure(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("project", help="project name (projects/<name>/)")
    parser.add_argument("--run-dir", type=Path, default=None,
                        help="directory for sockets and run files (default: a fresh temp dir)")
    parser.add_argument("--launcher", choices=("fork", "exec"), default=None,
                        help="override [supervisor] launcher")
    parser.add_argument("-v", "--verbose", action="store_true", help="debug logging")
    parser.add_argument("--node", default=None,
                        help="with [nodes]: run this node's share of the project "
                             "(its components and the bus proxy with its CurveZMQ links)")
    parser.add_argument("--no-tui", action="store_true",
                        help="log lines on stderr instead of the dashboard (the default when "
                             "stdin, stdout or stderr is not a terminal)")


def wants_tui(args: argparse.Namespace) -> bool:
    """The dashboard opens unless --no-tui, or not all of stdin/stdout/stderr are TTYs."""
    if getattr(args, "no_tui", False):
        return False
    try:
        return all(os.isatty(fd) for fd in (0, 1, 2))
    except OSError:
        return False


def run_dir_for(config: ProjectConfig, override: Path | None) -> Path:
    """--run-dir, else [supervisor] run_dir (relative to the project), else a temp dir."""
    if override is not None:
        path = override
    elif config.supervisor.run_dir:
        path = config.directory / config.supervisor.run_dir
    else:
        return Path(tempfile.mkdtemp(prefix=f"mrss-{config.name}-"))
    path.mkdir(parents=True, exist_ok=True)
    return path.resolve()


def pick_node(config: ProjectConfig, wanted: str | None) -> str:
    """The node to run: "" for a single-host project; ConfigError for a missing, unknown
    or superfluous --node."""
    plan = node_plan(config)
    if not plan.multi:
        if wanted:
            raise ConfigError("--node given, but the project declares no [nodes]",
                              file=str(config.file), key="nodes")
        return ""
    if not wanted:
        raise ConfigError(f"the project runs on nodes {', '.join(plan.nodes)}: say which "
                          "one this is with --node NAME", file=str(config.file), key="nodes")
    bus = config.sections.get("bus", {})
    if isinstance(bus, dict) and bus.get("delivery") == "direct":
        raise ConfigError("direct delivery is for one host; a project on [nodes] runs its "
                          "bus through each node's proxy: remove delivery = \"direct\"",
                          file=str(config.file), key="bus.delivery")
    name = plan.check_node(wanted).name
    from mrss.bus.curve import load_keys, load_public  # CurveZMQ: for [nodes] only

    folder = keys_dir(config)
    load_keys(folder, name)  # this node's keys, and every peer's public key: now, not in
    for peer in plan.nodes:  # the bus proxy's start
        load_public(folder, peer)
    return name


def log_rotation(config: ProjectConfig) -> logfile.Rotation:
    """The project's `[logs]`: when the run's log file is rotated, how many are kept."""
    table = config.sections.get("logs", {})
    if not isinstance(table, dict):
        raise ConfigError("must be a table", file=str(config.file), key="logs")
    return logfile.Rotation.of_table(table, file=str(config.file))


def run(args: argparse.Namespace) -> int:
    level = logging.DEBUG if args.verbose else logging.INFO
    logs.configure(args.project, level=level)
    try:
        config = load_project(args.project)
    except ConfigError as exc:
        print(f"mrss supervise: {exc}", file=sys.stderr)
        return EXIT_CONFIG
    tui = wants_tui(args)
    forking = not tui and (args.launcher or config.supervisor.launcher) != "exec"
    if not forking and not verify(config):
        return not_started(config, args.project)
    try:
        node = pick_node(config, args.node)
        rotation = log_rotation(config)
    except ConfigError as exc:
        print(f"mrss supervise: {exc}", file=sys.stderr)
        return EXIT_CONFIG
    os.environ[logfile.ENV] = rotation.to_env()  # every process of the tree rotates alike
    if tui:
        from mrss.commands.supervise_tui import run_with_dashboard  # imports Textual

        return run_with_dashboard(args, config)
    early: list[int] = []  # a stop asked for before the supervisor runs is kept, not lost
    for sig in (signal.SIGINT, signal.SIGTERM):
        signal.signal(sig, lambda signum, frame: early.append(signum))
    if node:
        os.environ[NODE_ENV] = node  # every process of this node's tree: SupEvent.node
    # The fork server starts now (the environment above is what every component gets),
    # imports the component code while the root sets up, and checks the project in a
    # child of its own: the root never imports that code (docs/supervision.md, "Start").
    remembered = False
    if forking:  # what the check would read, as seen here (docs/supervision.md, "Start")
        os.environ[passed.ENV] = digest = passed.key(config.directory)
        remembered = passed.remembered(digest)
    server = early_fork_server(config, node) if forking else None
    from mrss.commands.supervise_root import supervise  # meanwhile (bus, supervisor, ...)

    if server is not None and not remembered and not checked_by(server, config):
        server.close()
        return not_started(config, args.project)
    run_dir = run_dir_for(config, args.run_dir)
    temporary = args.run_dir is None and not config.supervisor.run_dir
    logs.configure(config.name, level=level, file=logs.log_file(run_dir))
    if remembered:
        logging.getLogger("mrss.supervise").info(
            "check skipped: an earlier start checked the project as it is now")
    try:
        return supervise(config, run_dir, args.launcher, early, node, server)
    except ConfigError as exc:
        print(f"mrss supervise: {exc}", file=sys.stderr)
        return EXIT_CONFIG
    finally:
        # Everything has stopped: a stop asked for now has nothing left to do. Ignored,
        # so it cannot kill the interpreter while it shuts down (Python restores the
        # default handlers then, and the exit status would be "killed by SIGTERM").
        for sig in (signal.SIGINT, signal.SIGTERM):
            signal.signal(sig, signal.SIG_IGN)
        if temporary:
            shutil.rmtree(run_dir, ignore_errors=True)


def verify(config: ProjectConfig) -> bool:
    """`mrss check`'s checks in this process (imports every component's code)."""
    from mrss.commands.check import verify as check_project

    return check_project(config)


def not_started(config: ProjectConfig, project: str) -> int:
    """A deterministic mistake is reported, never crash-looped."""
    print(f"mrss supervise: {config.name}: not started; fix the errors above "
          f"(`mrss check {project}`)", file=sys.stderr)
    return EXIT_CONFIG


def early_fork_server(config: ProjectConfig, node: str) -> ForkLauncher:
    """The fork server of this run, started before the supervisor (which takes it over)."""
    return ForkLauncher.early(
        preload_modules(c.start.target for c in root_children(config, node)),
        path=[config.directory])


def checked_by(server: ForkLauncher, config: ProjectConfig) -> bool:
    """Whether the project may start, checked by the fork server (here if it cannot)."""
    try:
        return server.check(CHECK, config.file)
    except SupervisionError as exc:
        logging.getLogger("mrss.supervise").warning("%s: checking here", exc)
        return verify(config)
