"""Where project folders live, and which projects exist."""

from __future__ import annotations

import os
from pathlib import Path

from mrss.errors import UnknownProjectError

PROJECT_FILE = "project.toml"


def projects_dir() -> Path:
    """The folder holding `projects/<name>/`: $MRSS_PROJECTS, ./projects, or the source tree's."""
    env = os.environ.get("MRSS_PROJECTS")
    if env:
        return Path(env).resolve()
    local = Path.cwd() / "projects"
    if local.is_dir():
        return local.resolve()
    return (Path(__file__).resolve().parent.parent / "projects").resolve()


def known_projects(base: Path | None = None) -> list[str]:
    """Names of the folders under the projects directory that hold a project.toml."""
    root = base or projects_dir()
    if not root.is_dir():
        return []
    return sorted(p.name for p in root.iterdir() if (p / PROJECT_FILE).is_file())


def project_path(name: str, base: Path | None = None) -> Path:
    """The folder of project `name`; UnknownProjectError lists the known ones."""
    root = base or projects_dir()
    path = root / name
    if name in ("", ".", "..") or "/" in name or "\0" in name or not _is_file(path / PROJECT_FILE):
        raise UnknownProjectError(name, known_projects(root))
    return path


def _is_file(path: Path) -> bool:
    try:
        return path.is_file()
    except OSError:  # e.g. a name too long for the file system
        return False
