"""The user's cache folder: what MRSS rebuilds only when its inputs change.

`$XDG_CACHE_HOME`, else `~/.cache` (the XDG base directory specification). MRSS keeps
its own things under `mrss/` there (the AgentSpeak parser tables, remembered project
checks); the benchmarks keep their peers under `mrss-bench/`.
"""

from __future__ import annotations

import os
from pathlib import Path


def base() -> Path:
    """The user's cache folder (RuntimeError when there is no home folder to find)."""
    return Path(os.environ.get("XDG_CACHE_HOME") or Path.home() / ".cache")


def folder() -> Path:
    """MRSS's folder in it."""
    return base() / "mrss"
