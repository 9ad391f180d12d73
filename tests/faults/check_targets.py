"""Checks the fork server runs in the tests of its early start (tests/faults/
test_early_fork_server.py): each is given the project file and says whether it may start."""

from __future__ import annotations

import os
import sys
from pathlib import Path


def accept(path: str) -> bool:
    Path(path).with_suffix(".checked").write_text(str(os.getpid()))
    return True


def refuse(path: str) -> bool:
    print(f"{path}: refused by the test's check", file=sys.stderr)
    return False


def crash(path: str) -> bool:
    raise RuntimeError("a check that fails")
