"""Fixtures of the end-to-end tests: a running MRSS system per test, always torn down."""

from __future__ import annotations

from collections.abc import Iterator

import pytest

from tests.e2e.system import System, running_system


@pytest.fixture()
def system() -> Iterator[System]:
    """`mrss supervise e2e` in a fresh run dir (short ipc paths), ready for percepts."""
    with running_system() as sys_:
        yield sys_
