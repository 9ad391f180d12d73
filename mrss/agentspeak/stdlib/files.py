"""The file system as data: `.list_files(Folder, L)` and `.list_files(Folder, Pattern, L)`,
as Jason's list_files.java."""

from __future__ import annotations

import os
import re
from typing import Any

from mrss.agentspeak.registry import IAContext
from mrss.agentspeak.stdlib import STDLIB
from mrss.agentspeak.terms import deref, term_str


@STDLIB.action(".list_files", min_args=2, max_args=3)
def list_files(ctx: IAContext, args: list[Any]) -> bool:
    """L is the paths of the files under Folder (its sub-folders too) whose name matches
    Pattern (a regular expression matching the whole name; default every file), each
    as the folder's path joined with the name; a folder that does not exist gives [].
    The order is by name, where Jason gives the file system's."""
    folder = deref(args[0])
    pattern = deref(args[1]) if len(args) == 3 else ".*"
    if type(folder) is not str or type(pattern) is not str:
        raise ctx.error(f"the folder and the pattern must be strings, not "
                        f"{term_str(folder)} and {term_str(pattern)}")
    try:
        match = re.compile(pattern).fullmatch
    except re.error as exc:
        raise ctx.error(f"bad pattern {pattern!r}: {exc}") from None
    found: list[str] = []
    _walk(folder.rstrip("/") or "/", match, found)
    return ctx.unify(args[-1], tuple(found))


def _walk(folder: str, match: Any, found: list[str]) -> None:
    try:
        entries = sorted(os.scandir(folder), key=lambda e: e.name)
    except OSError:
        return
    for entry in entries:
        path = os.path.join(folder, entry.name)
        if entry.is_file():
            if match(entry.name):
                found.append(path)
        elif entry.is_dir():
            _walk(path, match, found)
