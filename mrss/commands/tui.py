"""`mrss tui PROJECT [--run-dir DIR] [--endpoints FRONTEND BACKEND]`: the dashboard.

Connects to the bus of a running `mrss supervise PROJECT` (see `mrss.tui.discovery` for
how the bus is found) and shows the supervision tree, robots, actions, the reasoner's
mind and the log, with operator commands. `q` detaches: the system keeps running.
`--readonly` refuses every control. With users configured (`mrss users`) it opens on a
login (or takes `MRSS_OPERATOR_TOKEN`). `--web` serves the same dashboard to browsers
(`mrss.tui.web`: loopback by default, `--host`, `--port`, `--tls-cert`/`--tls-key`).
Exits 0 when closed, 2 if no bus is found or the web console may not start.

`mrss tui --replay FILE [PROJECT] [--speed X] [--paused]`: the same dashboard driven by
a recording of `mrss record` (MCAP, or the older format), read-only, with a timeline
(mrss/tui/replay/). The project's `[operator]`, `[map]` and `[[alerts]]` tables come
from PROJECT if given, else from the project.toml kept in the recording. Exits 2 if the
file is not a recording (the error gives the byte offset).
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path
from typing import TYPE_CHECKING

from mrss.errors import ConfigError, UnknownProjectError
from mrss.tui.polls import DEFAULT_POLLS

if TYPE_CHECKING:
    from mrss.tui.login import Login

EXIT_NO_BUS = 2
DEFAULT_WEB_HOST = "127.0.0.1"
DEFAULT_WEB_PORT = 8566


def configure(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("project", nargs="?", default=None,
                        help="project name (projects/<name>/); with --replay, optional")
    parser.add_argument("--run-dir", type=Path, default=None,
                        help="the run dir of `mrss supervise` (its ipc bus sockets)")
    parser.add_argument("--endpoints", nargs=2, metavar=("FRONTEND", "BACKEND"), default=None,
                        help="bus endpoints, e.g. tcp://127.0.0.1:5601 tcp://127.0.0.1:5602")
    parser.add_argument("--agent", default="",
                        help="the reasoner to inspect (default: any that answers)")
    parser.add_argument("--mind-every", type=float, default=DEFAULT_POLLS.mind_every,
                        metavar="S",
                        help="ask for a mind snapshot every S seconds (0: only on m)")
    parser.add_argument("--tree-every", type=float, default=DEFAULT_POLLS.tree_every,
                        metavar="S",
                        help="ask the supervisor for its tree every S seconds (0: only on F5)")
    parser.add_argument("--world-every", type=float, default=DEFAULT_POLLS.world_every,
                        metavar="S",
                        help="ask the world model for its objects (the map) every S seconds "
                             "(0: only on connecting and F5)")
    parser.add_argument("--stale-after", type=float, default=DEFAULT_POLLS.stale_after,
                        metavar="S",
                        help="turn the header red when nothing came from the system for S "
                             "seconds (default 5)")
    parser.add_argument("--replay", type=Path, default=None, metavar="FILE",
                        help="show a recording (mrss record) instead of a running system")
    parser.add_argument("--speed", type=float, default=1.0, metavar="X",
                        help="with --replay: the speed to start at (0.5 to 20; default 1)")
    parser.add_argument("--paused", action="store_true",
                        help="with --replay: start paused at the beginning")
    parser.add_argument("--readonly", action="store_true",
                        help="watch only: every control (percepts, goals, cancel, teleop, "
                             "faults, stop, recordings) is refused")
    web = parser.add_argument_group("the console in a browser")
    web.add_argument("--web", action="store_true",
                     help="serve the dashboard to browsers (each logs in) instead of "
                          "showing it here")
    web.add_argument("--host", default=DEFAULT_WEB_HOST,
                     help="address to serve on (default 127.0.0.1; another one only for "
                          "a project with users)")
    web.add_argument("--port", type=int, default=DEFAULT_WEB_PORT,
                     help=f"port to serve on (default {DEFAULT_WEB_PORT})")
    web.add_argument("--tls-cert", type=Path, default=None, metavar="PEM",
                     help="serve https with this certificate (and --tls-key)")
    web.add_argument("--tls-key", type=Path, default=None, metavar="PEM",
                     help="the certificate's private key")


def run(args: argparse.Namespace) -> int:
    if args.replay is not None:
        from mrss.commands.tui_replay import run_replay  # Textual only when needed

        return run_replay(args)
    if args.project is None:
        print("mrss tui: a project name is needed (or --replay FILE)", file=sys.stderr)
        return EXIT_NO_BUS
    if args.web:
        return serve_web(args)
    from mrss.tui.discovery import find_endpoints  # Textual is imported only when needed

    try:
        endpoints, name = find_endpoints(args.project, run_dir=args.run_dir,
                                   endpoints=args.endpoints)
    except (ConfigError, UnknownProjectError) as exc:
        print(f"mrss tui: {exc}", file=sys.stderr)
        return EXIT_NO_BUS
    from mrss.config.alerts import project_alert_rules
    from mrss.config.loader import load_project
    from mrss.tui.app import MrssApp
    from mrss.tui.mission import project_map, project_mission, run_dir_of
    from mrss.tui.vocabulary import Vocabulary, project_agent_files

    try:
        config = load_project(args.project)
        mission = project_mission(config.directory, config.file, config.sections,
                                  args.run_dir or run_dir_of(endpoints.backend))
        rules = project_alert_rules(config.sections, str(config.file))
        map_config = project_map(config.file, config.sections)
    except (ConfigError, UnknownProjectError) as exc:
        print(f"mrss tui: {exc}", file=sys.stderr)
        return EXIT_NO_BUS
    login = operator_login(config.directory)
    if isinstance(login, str):
        print(f"mrss tui: {login}", file=sys.stderr)
        return EXIT_NO_BUS
    budget = (config.supervisor.spec.intensity, config.supervisor.spec.period)
    vocabulary = Vocabulary.of_files(project_agent_files(config.components, config.directory))
    app = MrssApp(endpoints, project=name, agent=args.agent, mission=mission,
                  restart_budget=budget, vocabulary=vocabulary, alert_rules=rules,
                  mind_every=args.mind_every, tree_every=args.tree_every,
                  readonly=args.readonly, stale_after=args.stale_after,
                  world_every=args.world_every, map_config=map_config, quiet_gc=True,
                  login=login)
    app.run()
    ended = app.liveness.ended
    print(f"mrss tui: {name}: {ended}" if ended else
          f"mrss tui: detached from {name}; it keeps running", file=sys.stderr)
    return 0


def operator_login(project_dir: Path) -> Login | None | str:
    """The project's login (None: no users configured), logged in already when
    `MRSS_OPERATOR_TOKEN` holds a personal token; a str says why that token is refused."""
    import os

    from mrss.auth.store import AuthError, configured, store_path
    from mrss.tui.login import TOKEN_ENV, Login

    if not configured(project_dir):
        return None
    login = Login(store_path(project_dir))
    token = os.environ.get(TOKEN_ENV)
    if token:
        try:
            login.login_with_token(token)
        except (AuthError, ConfigError) as exc:
            return f"${TOKEN_ENV} refused: {exc}"
    return login


def serve_web(args: argparse.Namespace) -> int:
    """`--web`: serve this same command (without --web) to browsers."""
    import shlex

    from mrss.auth.store import configured
    from mrss.config.projects import project_path
    from mrss.tui.web import WebConsole, WebProblem, exposure_problem, tls_context

    try:
        problem = exposure_problem(args.host, configured(project_path(args.project)))
        if problem:
            raise WebProblem(problem)
        tls = tls_context(args.tls_cert, args.tls_key)
    except (WebProblem, UnknownProjectError) as exc:
        print(f"mrss tui --web: {exc}", file=sys.stderr)
        return EXIT_NO_BUS
    if tls is None and args.host != DEFAULT_WEB_HOST:
        print(f"mrss tui --web: warning: no TLS on {args.host}: passwords cross the network "
              "in clear (--tls-cert, --tls-key)", file=sys.stderr)
    command = [sys.executable, "-m", "mrss", "tui", args.project, *_forwarded(args)]
    WebConsole(shlex.join(command), host=args.host, port=args.port,
               title=f"MRSS {args.project}", tls=tls).serve()
    return 0


def _forwarded(args: argparse.Namespace) -> list[str]:
    """The options of this command that each browser's dashboard gets too."""
    out: list[str] = []
    if args.run_dir is not None:
        out += ["--run-dir", str(args.run_dir)]
    if args.endpoints:
        out += ["--endpoints", *args.endpoints]
    if args.agent:
        out += ["--agent", args.agent]
    for flag, value in (("--mind-every", args.mind_every), ("--tree-every", args.tree_every),
                        ("--world-every", args.world_every),
                        ("--stale-after", args.stale_after)):
        out += [flag, repr(float(value))]
    if args.readonly:
        out.append("--readonly")
    return out
