"""A fork server started before its supervisor: it checks the project in a child of its
own, and the supervisor then takes it over and forks its components from it."""

from __future__ import annotations

import os
from collections.abc import Iterator
from pathlib import Path

import psutil
import pytest

from mrss.errors import SupervisionError
from mrss.supervision.children import ProcessSettings
from mrss.supervision.events import EventLog
from mrss.supervision.launchers import ForkLauncher, preload_modules
from mrss.supervision.process import ProcessSupervisor
from mrss.supervision.spec import SupervisorSpec
from mrss.testing import process_gone
from tests.faults.conftest import HEARTBEAT, MISSES, WORKER, worker

TARGETS = "tests.faults.check_targets"


@pytest.fixture()
def early() -> Iterator[ForkLauncher]:
    launcher = ForkLauncher.early(preload_modules([WORKER, f"{TARGETS}:accept"]), path=[])
    yield launcher
    launcher.close()


def test_the_check_runs_in_a_child_of_the_fork_server_and_says_yes_or_no(
        early: ForkLauncher, tmp_path: Path) -> None:
    project = tmp_path / "project.toml"
    project.write_text("")
    assert early.check(f"{TARGETS}:accept", project)
    checker = int(project.with_suffix(".checked").read_text())
    assert checker not in (os.getpid(), early.server_pid)  # a child of the server, gone
    assert process_gone(checker)
    assert not early.check(f"{TARGETS}:refuse", project)
    assert not early.check(f"{TARGETS}:crash", project)  # a check that fails refuses
    assert psutil.Process(early.server_pid).is_running()  # the server itself goes on


def test_a_lost_fork_server_makes_the_check_fail_loudly(early: ForkLauncher,
                                                        tmp_path: Path) -> None:
    early.start()
    psutil.Process(early.server_pid).kill()
    with pytest.raises(SupervisionError):
        early.check(f"{TARGETS}:accept", tmp_path / "project.toml")


def test_the_supervisor_takes_the_early_fork_server_over(early: ForkLauncher,
                                                          tmp_path: Path) -> None:
    project = tmp_path / "project.toml"
    project.write_text("")
    assert early.check(f"{TARGETS}:accept", project)
    server = early.server_pid
    settings = ProcessSettings(tmp_path, tmp_path, heartbeat_interval=HEARTBEAT,
                               heartbeat_misses=MISSES)
    log = EventLog()
    sup = ProcessSupervisor("root", SupervisorSpec(), [worker("a"), worker("b")], settings,
                            publish=log, fork_server=early)
    sup.start()
    try:
        assert sup.wait_started(30), "children did not start"
        for child in ("a", "b"):
            assert psutil.Process(sup.pid_of(child)).ppid() == server
        assert sup.ping("a") and sup.ping("b")
    finally:
        sup.stop(timeout=30)
    assert log.of("restart") == []  # the same server throughout: no launcher restart
