"""A clean check remembered by what it read: a start of an unchanged project skips it.

`mrss supervise` checks the project before it starts anything (the fork server runs
`mrss check`'s checks in a child: 0.25 to 0.3 s of a start of wildfire, after its
imports). A check that found nothing at all (no error, no warning) is remembered under
a key made of everything it could have read:
- every file under the project's folder (names, contents and permission bits; caches
  left out);
- MRSS's own code (each module's path, size and modification time);
- the interpreter and the installed packages (Python's version, the site-packages
  folder's modification time, which any install or removal changes);
- the names of the environment variables (a project may name one, such as the world
  model's token), and the values of those that start with `MRSS_`.

A project on several nodes (`[nodes]`) is never remembered: its keys may live outside
its folder.

The root supervisor computes the key before it starts the fork server and hands it
down (`MRSS_CHECK_KEY`), so the check remembers what the root saw: the fork server's
imports may set variables of their own (pymavlink sets MAVLINK_DIALECT).

A start whose key is remembered does not check again (`remembered`); anything changed
is another key, so the check runs, and a check with findings is never remembered (they
are printed at every start). The entries are empty files named by the key under the
user's cache folder (`$XDG_CACHE_HOME/mrss/checks`, else `~/.cache/mrss/checks`); a
folder that cannot be written only means every start checks.
"""

from __future__ import annotations

import hashlib
import os
import sys
import sysconfig
from pathlib import Path

from mrss import usercache

SKIPPED = {"__pycache__", ".mypy_cache", ".pytest_cache", ".ruff_cache", ".git"}
MRSS = Path(__file__).resolve().parent.parent  # the mrss package's folder
KEEP = 64  # entries kept (the oldest go first)
ENV = "MRSS_CHECK_KEY"  # the key the root computed, for the check it asks for


def folder() -> Path:
    return usercache.folder() / "checks"


def key(project_dir: Path) -> str:
    """What a check of the project in `project_dir` reads, as one digest."""
    h = hashlib.sha256()
    h.update(sys.version.encode())
    try:
        h.update(str(os.stat(sysconfig.get_paths()["purelib"]).st_mtime_ns).encode())
    except OSError:
        pass
    for name in sorted(os.environ):
        if name == ENV:
            continue
        value = os.environ[name] if name.startswith("MRSS_") else ""
        h.update(f"{name}={value}\0".encode())
    for path in _files(MRSS, (".py", ".lark", ".json", ".toml")):
        st = path.stat()
        h.update(f"{path}\0{st.st_size}\0{st.st_mtime_ns}\0".encode())
    for path in _files(project_dir.resolve(), None):
        h.update(f"{path.relative_to(project_dir.resolve())}\0{path.stat().st_mode}\0".encode())
        h.update(hashlib.sha256(path.read_bytes()).digest())
    return h.hexdigest()


def _files(root: Path, suffixes: tuple[str, ...] | None) -> list[Path]:
    found: list[Path] = []
    for top, dirs, files in os.walk(root):
        dirs[:] = sorted(d for d in dirs if d not in SKIPPED and not d.startswith("."))
        found += [Path(top) / f for f in sorted(files)
                  if suffixes is None or f.endswith(suffixes)]
    return found


def remembered(digest: str) -> bool:
    """Whether a clean check is remembered under `digest` (a `key`)."""
    try:
        return (folder() / digest).is_file()
    except OSError:
        return False


def remember(project_dir: Path) -> None:
    """The check of the project as it is now found nothing: remember it (under the
    key its root handed down, else the one seen here)."""
    try:
        digest = os.environ.get(ENV) or key(project_dir)
        where = folder()
        where.mkdir(parents=True, exist_ok=True)
        (where / digest).touch()
        entries = sorted(where.iterdir(), key=lambda p: p.stat().st_mtime_ns)
        for old in entries[:-KEEP]:
            old.unlink(missing_ok=True)
    except OSError:
        pass  # not remembered: the next start checks again
