"""`mrss tui --replay FILE [PROJECT]`: the dashboard over a recording (see `mrss tui`).

Reads the file, indexes it for seeking (mrss/tui/replay/index.py), and runs the replay
dashboard; the project's dashboard tables come from PROJECT, else from the recording.
A file that is not a recording exits 2 with the offset; a recording damaged part way is
shown up to the damage, and the damage is said on stderr.
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path
from typing import Any

from mrss.errors import ConfigError, UnknownProjectError
from mrss.recording.format import RecordingError

EXIT_ERROR = 2


def run_replay(args: argparse.Namespace) -> int:
    from mrss.tui.replay.player import speed_in_range
    from mrss.tui.replay.tape import Tape

    path: Path = args.replay
    try:
        speed = speed_in_range(args.speed)
    except ValueError as exc:
        print(f"mrss tui: --speed: {exc}", file=sys.stderr)
        return EXIT_ERROR
    try:
        tape = Tape.load(path)
    except OSError as exc:
        print(f"mrss tui: cannot read {path}: {exc.strerror or exc}", file=sys.stderr)
        return EXIT_ERROR
    except RecordingError as exc:
        print(f"mrss tui: {path}: {exc}", file=sys.stderr)
        return EXIT_ERROR
    try:
        settings = dashboard_settings(args.project, tape.sections(), str(path))
    except (ConfigError, UnknownProjectError) as exc:
        print(f"mrss tui: {exc}", file=sys.stderr)
        return EXIT_ERROR
    from mrss.tui.replay.app import ReplayApp

    # made first: its index pass reads the file once (a finished recording is read a
    # chunk at a time, and its damage found then)
    app = ReplayApp(tape, name=path.name, speed=speed, play=not args.paused,
                    project=args.project or tape.project, agent=args.agent,
                    quiet_gc=True, **settings)
    if tape.damage is not None:
        print(f"mrss tui: {path}: {tape.damage} (shown up to there)", file=sys.stderr)
    if not tape.frames:
        print(f"mrss tui: {path}: the recording holds no bus messages to show",
              file=sys.stderr)
        return EXIT_ERROR
    app.run()
    return 0


def dashboard_settings(project: str | None, recorded: dict[str, Any],
                       where: str) -> dict[str, Any]:
    """The dashboard's project tables: PROJECT's, else the recording's project.toml's
    (`where` names it in errors); ConfigError naming the table if one is wrong."""
    from mrss.config.alerts import project_alert_rules
    from mrss.config.map import SECTION as MAP_SECTION
    from mrss.config.map import read_map
    from mrss.config.operator import SECTION as OPERATOR_SECTION
    from mrss.config.operator import read_operator
    from mrss.tui.vocabulary import Vocabulary, project_agent_files

    settings: dict[str, Any] = {}
    sections, file = recorded, f"{where} (its project.toml)"
    if project:
        from mrss.config.loader import load_project

        config = load_project(project)
        sections, file = config.sections, str(config.file)
        settings["vocabulary"] = Vocabulary.of_files(
            project_agent_files(config.components, config.directory))
        settings["restart_budget"] = (config.supervisor.spec.intensity,
                                      config.supervisor.spec.period)
    if OPERATOR_SECTION in sections:
        settings["operator_config"] = read_operator(sections[OPERATOR_SECTION], file=file)
    settings["alert_rules"] = project_alert_rules(sections, file)
    settings["map_config"] = read_map(sections.get(MAP_SECTION), file=file)
    return settings
