"""`mrss tui PROJECT [--run-dir DIR] [--endpoints FRONTEND BACKEND]`: the dashboard.

Connects to the bus of a running `mrss supervise PROJECT` (see `mrss.tui.discovery` for
how the bus is found) and shows the supervision tree, robots, actions, the reasoner's
mind and the log, with operator commands. `q` detaches: the system keeps running.
`--readonly` refuses every control. Exits 0 when closed, 2 if no bus is found.

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

from mrss.errors import ConfigError, UnknownProjectError
from mrss.tui.polls import DEFAULT_POLLS

EXIT_NO_BUS = 2


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


def run(args: argparse.Namespace) -> int:
    if args.replay is not None:
        from mrss.commands.tui_replay import run_replay  # Textual only when needed

        return run_replay(args)
    if args.project is None:
        print("mrss tui: a project name is needed (or --replay FILE)", file=sys.stderr)
        return EXIT_NO_BUS
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
    budget = (config.supervisor.spec.intensity, config.supervisor.spec.period)
    vocabulary = Vocabulary.of_files(project_agent_files(config.components, config.directory))
    app = MrssApp(endpoints, project=name, agent=args.agent, mission=mission,
                  restart_budget=budget, vocabulary=vocabulary, alert_rules=rules,
                  mind_every=args.mind_every, tree_every=args.tree_every,
                  readonly=args.readonly, stale_after=args.stale_after,
                  world_every=args.world_every, map_config=map_config, quiet_gc=True)
    app.run()
    ended = app.liveness.ended
    print(f"mrss tui: {name}: {ended}" if ended else
          f"mrss tui: detached from {name}; it keeps running", file=sys.stderr)
    return 0
