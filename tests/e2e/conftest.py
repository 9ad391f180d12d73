"""Fixtures of the end-to-end tests: a running MRSS system per test, always torn down."""

from __future__ import annotations

import os
import shutil
import tempfile
from collections.abc import Iterator
from pathlib import Path

import psutil
import pytest

from tests.e2e.system import System


def _descendants() -> set[int]:
    return {p.pid for p in psutil.Process().children(recursive=True)}


@pytest.fixture()
def system() -> Iterator[System]:
    """`mrss supervise e2e` in a fresh run dir (short ipc paths), ready for percepts."""
    before = _descendants()
    run_dir = Path(tempfile.mkdtemp(prefix="mrss-e2e-"))
    sys_ = System(run_dir)
    try:
        sys_.wait_ready()
        yield sys_
    finally:
        tree = psutil.Process(sys_.proc.pid).children(recursive=True) \
            if sys_.proc.poll() is None else []
        sys_.close()
        left = [p for p in tree if p.is_running() and p.status() != psutil.STATUS_ZOMBIE]
        for p in left:
            p.kill()
        if not os.environ.get("MRSS_E2E_KEEP"):
            shutil.rmtree(run_dir, ignore_errors=True)
        assert not left, f"processes left behind: {[p.pid for p in left]}"
        assert _descendants() <= before | {sys_.proc.pid}
