"""How deeply terms and rule recursion may nest, and Python's recursion limit for it.

Parsing, unification and queries are recursive; Python's default limit (1000 frames)
would stop at terms about 300 deep. Agents raise the limit to `RUNTIME_FRAMES` (never
lower it); the parser accepts terms nested up to `PARSE_DEPTH` levels and reports
deeper ones as a syntax error. A recursion that still exceeds the limit (an endless
rule, a cyclic term) fails its intention with `DEPTH_ERROR`, naming file and line.
"""

from __future__ import annotations

import contextlib
import sys
from collections.abc import Iterator

PARSE_DEPTH = 500  # nesting of terms in one statement that parses
_FRAMES_PER_LEVEL = 8  # Python frames per nesting level in the parse-tree transformer
RUNTIME_FRAMES = 4000
DEPTH_ERROR = "deep_recursion"  # the Jason error atom of a RecursionError


def ensure_recursion_limit(frames: int = RUNTIME_FRAMES) -> None:
    """Raise Python's recursion limit to at least `frames` (it is never lowered)."""
    if sys.getrecursionlimit() < frames:
        sys.setrecursionlimit(frames)


@contextlib.contextmanager
def deep_recursion(frames: int = PARSE_DEPTH * _FRAMES_PER_LEVEL) -> Iterator[None]:
    """Allow `frames` Python frames inside the block; the old limit is restored."""
    old = sys.getrecursionlimit()
    if old >= frames:
        yield
        return
    sys.setrecursionlimit(frames)
    try:
        yield
    finally:
        sys.setrecursionlimit(old)


def depth_message(what: str) -> str:
    return (f"{what}: recursion too deep (an endless recursive rule, a cyclic term such "
            f"as X = [1|X], or a term nested more than about {PARSE_DEPTH} levels)")
