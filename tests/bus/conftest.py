"""Fixtures for bus tests: short run directories, bus processes that are always cleaned up."""

from __future__ import annotations

import json
import shutil
import sys
import tempfile
from collections.abc import Iterator
from pathlib import Path

import pytest

from mrss.bus import BusEndpoints, ProxyThread
from mrss.errors import BusError
from tests.bus.bus_helpers import BusProcess, Spawn


@pytest.fixture()
def run_dir() -> Iterator[Path]:
    """A short directory for ipc sockets (unix socket paths are limited to 107 bytes)."""
    path = Path(tempfile.mkdtemp(prefix="mrss-bus-"))
    try:
        yield path
    finally:
        shutil.rmtree(path, ignore_errors=True)


@pytest.fixture(params=["ipc", "tcp", "ipc-direct", "tcp-direct"])
def endpoints(request: pytest.FixtureRequest, run_dir: Path) -> BusEndpoints:
    """Default ipc endpoints in the run directory, or tcp on free loopback ports; each
    also with direct delivery (mrss/bus/direct.py), where the proxy only introduces."""
    direct = request.param.endswith("-direct")
    if request.param.startswith("ipc"):
        return BusEndpoints.ipc(run_dir, direct=direct)
    return BusEndpoints.tcp_loopback(direct=direct)


@pytest.fixture()
def spawn() -> Iterator[Spawn]:
    """Start bus processes; every one is stopped at the end, even when the test fails."""
    started: list[BusProcess] = []

    def start_process(endpoints: BusEndpoints, mode: str, *args: str) -> BusProcess:
        if mode == "proxy":
            argv = [sys.executable, "-m", "mrss.bus.proxy", "--frontend", endpoints.frontend,
                    "--backend", endpoints.backend, *(["--direct"] if endpoints.direct else [])]
        else:
            argv = [sys.executable, "-m", "tests.bus.bus_peer",
                    json.dumps(endpoints.to_dict()), mode, *args]
        process = BusProcess(argv)
        started.append(process)
        return process.wait_ready()

    try:
        yield start_process
    finally:
        for process in reversed(started):
            process.stop()


@pytest.fixture()
def proxy_thread(endpoints: BusEndpoints) -> Iterator[BusEndpoints]:
    """A proxy on a thread of the test process; yields its endpoints."""
    proxy = ProxyThread(endpoints)
    for _ in range(3):
        try:
            proxy.start()
            break
        except BusError:
            if not endpoints.frontend.startswith("tcp://"):
                raise
            # Another process on this busy machine took a free port first: pick again.
            endpoints = BusEndpoints.tcp_loopback(direct=endpoints.direct)
            proxy = ProxyThread(endpoints)
    else:
        raise AssertionError("no free loopback ports for the proxy")
    try:
        yield endpoints
    finally:
        proxy.stop()
