"""Where a running system's bus is, for `mrss tui PROJECT`.

In order: `--endpoints FRONTEND BACKEND`; a tcp `[bus]` in project.toml; the ipc
sockets in `--run-dir`, in `[supervisor] run_dir`, or else in the newest
`$TMPDIR/mrss-<project>-*` directory (the temporary run dir `mrss supervise` makes
when it is given none) that holds a bus socket.
"""

from __future__ import annotations

import tempfile
from collections.abc import Sequence
from pathlib import Path

from mrss.bus import BusEndpoints
from mrss.bus.settings import endpoints_from_config
from mrss.config.loader import load_project
from mrss.errors import ConfigError

SOCKET = "bus-sub.sock"


def find_endpoints(project: str, *, run_dir: Path | None = None,
                   endpoints: Sequence[str] | None = None,
                   temp_dir: Path | None = None) -> tuple[BusEndpoints, str]:
    """The bus endpoints of `project`'s running system and its name (the root supervisor's);
    ConfigError if none can be found."""
    if endpoints:
        frontend, backend = endpoints
        return BusEndpoints(frontend, backend), project
    config = load_project(project)
    section = config.sections.get("bus", {})
    if not isinstance(section, dict):
        raise ConfigError("must be a table", file=str(config.file), key="bus")
    if section.get("transport", "ipc") != "ipc":
        return endpoints_from_config(section, None, file=str(config.file),
                                     nodes="nodes" in config.sections), config.name
    if run_dir is None and config.supervisor.run_dir:
        run_dir = config.directory / config.supervisor.run_dir
    if run_dir is None:
        run_dir = newest_run_dir(config.name, temp_dir)
    if run_dir is None:
        raise ConfigError(
            f"no running system of {config.name!r} found (no {SOCKET} in "
            f"{temp_dir or tempfile.gettempdir()}/mrss-{config.name}-*); pass --run-dir DIR "
            "(the run dir `mrss supervise` logs) or --endpoints FRONTEND BACKEND")
    return endpoints_from_config(section, run_dir.resolve(), file=str(config.file),
                                 nodes="nodes" in config.sections), config.name


def newest_run_dir(project: str, temp_dir: Path | None = None) -> Path | None:
    """The most recently started temporary run dir of `project` with a bus socket in it."""
    base = temp_dir or Path(tempfile.gettempdir())
    found = [p for p in base.glob(f"mrss-{project}-*") if (p / SOCKET).exists()]
    if not found:
        return None
    return max(found, key=lambda p: (p / SOCKET).stat().st_mtime)
