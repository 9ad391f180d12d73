"""Fixtures for the dashboard tests: a real bus proxy on tmp ipc sockets and a peer on it."""

from __future__ import annotations

import shutil
import tempfile
from collections.abc import Iterator
from pathlib import Path

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
