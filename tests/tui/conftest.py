"""Fixtures for the dashboard tests: a real bus proxy on tmp ipc sockets and a peer on it;
live systems (`mrss supervise busdemo` / `tuidemo` as real processes)."""

from __future__ import annotations

import os
import shutil
import signal
import subprocess
import sys
import tempfile
from collections.abc import Iterator
from pathlib import Path

import psutil
import pytest

from mrss.bus import BusEndpoints, ProxyThread
from tests.tui.tui_helpers import Peer


@pytest.fixture()
def endpoints() -> Iterator[BusEndpoints]:
    """A running proxy on ipc sockets in a short temp dir (unix socket paths are short)."""
    run_dir = Path(tempfile.mkdtemp(prefix="mrss-tui-"))
    ep = BusEndpoints.ipc(run_dir)
    proxy = ProxyThread(ep).start()
    try:
        yield ep
    finally:
        proxy.stop()
        shutil.rmtree(run_dir, ignore_errors=True)


@pytest.fixture()
def peer(endpoints: BusEndpoints) -> Iterator[Peer]:
    p = Peer(endpoints)
    try:
        yield p
    finally:
        p.close()


HERE = Path(__file__).resolve().parent
PROJECTS = HERE.parent / "projects"


def supervise(project: str, projects: Path, run_dir: Path) -> Iterator[Path]:
    """`mrss supervise PROJECT --run-dir run_dir` as a real process, stopped at the end."""
    env = {**os.environ, "MRSS_PROJECTS": str(projects)}
    proc = subprocess.Popen(
        [sys.executable, "-m", "mrss", "supervise", project, "--run-dir", str(run_dir)],
        env=env, stdout=subprocess.DEVNULL, stderr=subprocess.PIPE, text=True)
    try:
        yield run_dir
        proc.send_signal(signal.SIGTERM)
        _, err = proc.communicate(timeout=30)
        assert proc.returncode == 0, err
    finally:
        if proc.poll() is None:
            for child in psutil.Process(proc.pid).children(recursive=True):
                child.kill()
            proc.kill()
            proc.communicate(timeout=10)


@pytest.fixture()
def busdemo(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> Iterator[Path]:
    """tests/projects/busdemo running; its run dir."""
    monkeypatch.setenv("MRSS_PROJECTS", str(PROJECTS))
    yield from supervise("busdemo", PROJECTS, tmp_path)


@pytest.fixture()
def tuidemo() -> Iterator[Path]:
    """tests/tui/tuidemo (bus, RCL with two UGVs, reasoner, telemetry) running; its run dir."""
    run_dir = Path(tempfile.mkdtemp(prefix="mrss-tuidemo-"))
    try:
        yield from supervise("tuidemo", HERE, run_dir)
    finally:
        shutil.rmtree(run_dir, ignore_errors=True)


@pytest.fixture()
def tuimission() -> Iterator[Path]:
    """tests/tui/tuimission (bus, broker, events, RCL, the wildfire agent) running."""
    run_dir = Path(tempfile.mkdtemp(prefix="mrss-tuimission-"))
    try:
        yield from supervise("tuimission", HERE, run_dir)
    finally:
        shutil.rmtree(run_dir, ignore_errors=True)


@pytest.fixture()
def tuifleet() -> Iterator[Path]:
    """tests/tui/tuifleet (bus, RCL with three ground robots, an agent addressing fires
    to a role) running; its run dir."""
    run_dir = Path(tempfile.mkdtemp(prefix="mrss-tuifleet-"))
    try:
        yield from supervise("tuifleet", HERE, run_dir)
    finally:
        shutil.rmtree(run_dir, ignore_errors=True)
