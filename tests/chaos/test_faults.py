"""The fault injector on a real process: overlapping timed faults on one process."""

from __future__ import annotations

import os
import subprocess
import sys
from collections.abc import Iterator

import psutil
import pytest

from mrss.chaos.faults import Fault, FaultKind, Injector
from mrss.testing import wait_until

# A child that ignores SIGXFSZ (as MRSS components do) and waits to be killed.
CHILD = "import signal, sys; signal.signal(signal.SIGXFSZ, signal.SIG_IGN); " \
        "print('ready', flush=True); sys.stdin.read()"


@pytest.fixture()
def child() -> Iterator[psutil.Process]:
    proc = subprocess.Popen([sys.executable, "-c", CHILD], stdin=subprocess.PIPE,
                            stdout=subprocess.PIPE, text=True)
    assert proc.stdout is not None and proc.stdout.readline() == "ready\n"
    try:
        yield psutil.Process(proc.pid)
    finally:
        proc.kill()
        proc.wait(timeout=10)


def _injector(child: psutil.Process) -> Injector:
    return Injector(os.getpid(), lambda name: child.pid if name == "rcl" else None)


def _stopped(p: psutil.Process) -> bool:
    return p.status() == psutil.STATUS_STOPPED


def test_overlapping_full_disks_give_the_limit_back_when_the_last_is_over(
        child: psutil.Process) -> None:
    original = child.rlimit(psutil.RLIMIT_FSIZE)
    injector = _injector(child)
    _, heal_first = injector.inject(Fault(0.0, FaultKind.DISK_FULL, "rcl", 6.0))
    _, heal_second = injector.inject(Fault(4.0, FaultKind.DISK_FULL, "rcl", 2.0))
    assert heal_first is not None and heal_second is not None
    assert child.rlimit(psutil.RLIMIT_FSIZE)[0] == 0
    heal_first()
    assert child.rlimit(psutil.RLIMIT_FSIZE)[0] == 0  # the second is still on
    heal_first()  # a heal counts once
    assert child.rlimit(psutil.RLIMIT_FSIZE)[0] == 0
    heal_second()
    assert child.rlimit(psutil.RLIMIT_FSIZE) == original  # not the 0 of the first
    _, heal_third = injector.inject(Fault(9.0, FaultKind.DISK_FULL, "rcl", 2.0))
    assert heal_third is not None and child.rlimit(psutil.RLIMIT_FSIZE)[0] == 0
    heal_third()
    assert child.rlimit(psutil.RLIMIT_FSIZE) == original


def test_overlapping_hangs_resume_the_process_when_the_last_is_over(
        child: psutil.Process) -> None:
    injector = _injector(child)
    _, heal_hang = injector.inject(Fault(0.0, FaultKind.HANG, "rcl", 5.0))
    _, heal_again = injector.inject(Fault(2.0, FaultKind.HANG, "rcl", 5.0))
    assert heal_hang is not None and heal_again is not None
    wait_until(lambda: _stopped(child), timeout=10, message="the child stopped")
    heal_hang()
    assert _stopped(child)  # the second hang is still on (SIGCONT would be at once)
    heal_again()
    wait_until(lambda: not _stopped(child), timeout=10, message="the child resumed")
