"""The line a dotted key of a project.toml is on, so an error can name it.

Best effort, from the text alone (tomllib gives no positions): `a.b.c` is the line of
`c = ...` under the header `[a.b]` (spaces around the dots and brackets allowed); if no
such assignment is there, the line of a table header beginning `[a.b.c` (the key is
itself a table); failing that, the line of the `[a.b]`
header. A key of no table, `c`, is sought before the first header. None if nothing
matches.
"""

from __future__ import annotations

import re
from collections.abc import Sequence
from pathlib import Path

from mrss.textfile import NotUtf8Error, read_text


def line_of_key(lines: Sequence[str], key: str) -> int | None:
    """The line (from 1) of dotted `key` in a TOML text's `lines`; see the module docstring."""
    *table, last = key.split(".")
    header = re.compile(r"^\s*\[\s*" + r"\s*\.\s*".join(map(re.escape, table)) + r"\s*\]")
    assign = re.compile(r"^\s*" + re.escape(last) + r"\s*=")
    in_table = not table
    found = None
    for number, line in enumerate(lines, start=1):
        if line.lstrip().startswith("["):
            in_table = bool(table) and bool(header.match(line))
            if in_table and found is None:
                found = number
        elif in_table and assign.match(line):
            return number
    whole = re.compile(r"^\s*\[\s*" + r"\s*\.\s*".join(map(re.escape, [*table, last])))
    for number, line in enumerate(lines, start=1):
        if whole.match(line):
            return number
    return found


def key_line_number(path: Path, key: str) -> int | None:
    """The line of a dotted key (or of its table) in a project.toml, for error messages."""
    try:
        return line_of_key(read_text(path).splitlines(), key)
    except (OSError, NotUtf8Error):
        return None
