"""Fixtures for RCL tests: simulated robots, a journal file, an RCL core started in-process;
for the process tests (tests/actors/rcl/processes.py) their child processes and a short
run directory (a bus's IPC socket paths must stay short, so not pytest's tmp_path)."""

from __future__ import annotations

import shutil
import tempfile
from collections.abc import Iterator
from pathlib import Path

import pytest

from tests.actors.rcl.processes import Procs
from tests.actors.rcl.rcl_sim import RclEnv, SimRobot


@pytest.fixture()
def rcl_env(tmp_path: Path) -> Iterator[RclEnv]:
    env = RclEnv(tmp_path / "journal.sqlite3",
                 {"ugv1": SimRobot("ugv1"), "ugv2": SimRobot("ugv2"), "uav1": SimRobot("uav1")})
    try:
        yield env
    finally:
        for robot in env.robots.values():  # unblock any motion left waiting
            robot.halt()
        env.stop()
        assert not env.statuses.check_failures, env.statuses.check_failures


@pytest.fixture()
def procs() -> Iterator[Procs]:
    p = Procs()
    try:
        yield p
    finally:
        p.close()


@pytest.fixture()
def run_dir() -> Iterator[Path]:
    path = Path(tempfile.mkdtemp(prefix="mrss-rclp-"))
    try:
        yield path
    finally:
        shutil.rmtree(path, ignore_errors=True)
