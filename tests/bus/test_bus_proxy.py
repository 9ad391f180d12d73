"""The proxy process: stale socket files, a live proxy is not stolen from, clean shutdown."""

from __future__ import annotations

import socket
import subprocess
import sys
from pathlib import Path

import pytest

from mrss.bus import BusEndpoints, ProxyThread, Publisher, Subscriber
from mrss.errors import BusError
from mrss.messages import Percept
from tests.bus.bus_helpers import Spawn, sync


def _percept(k: int) -> Percept:
    return Percept(literal=f"sync({k})")


def _leave_stale_socket(path: Path) -> None:
    """A unix socket file with nobody listening, as a SIGKILLed proxy leaves behind."""
    s = socket.socket(socket.AF_UNIX, socket.SOCK_STREAM)
    s.bind(str(path))
    s.close()


def test_stale_socket_files_are_replaced(run_dir: Path) -> None:
    ep = BusEndpoints.ipc(run_dir)
    for path in ep.ipc_paths():
        _leave_stale_socket(path)
    with ProxyThread(ep), Publisher(ep, src="t") as pub, \
            Subscriber(ep, prefixes=["percept"]) as sub:
        sync(pub, sub, _percept)
    assert not any(p.exists() for p in ep.ipc_paths()), "a stopped proxy removes its sockets"


def test_a_second_proxy_does_not_steal_live_endpoints(run_dir: Path) -> None:
    ep = BusEndpoints.ipc(run_dir)
    with ProxyThread(ep):
        with pytest.raises(BusError, match="another bus proxy is listening"):
            ProxyThread(ep).start()
        with Publisher(ep, src="t") as pub, Subscriber(ep, prefixes=["percept"]) as sub:
            sync(pub, sub, _percept)  # the first proxy still serves


def test_a_port_in_use_is_a_bus_error() -> None:
    ep = BusEndpoints.tcp_loopback()
    with ProxyThread(ep), pytest.raises(BusError, match="cannot bind"):
        ProxyThread(ep).start()


def test_proxy_process_stops_cleanly_on_sigterm(run_dir: Path, spawn: Spawn) -> None:
    ep = BusEndpoints.ipc(run_dir)
    proxy = spawn(ep, "proxy")
    assert proxy.lines[0].startswith("ready {")
    assert all(p.exists() for p in ep.ipc_paths())
    proxy.proc.terminate()
    assert proxy.proc.wait(timeout=10) == 0
    assert not any(p.exists() for p in ep.ipc_paths())


@pytest.mark.parametrize(("args", "message"), [
    (["--frontend", "tcp://127.0.0.1:1"], "give either --run-dir"),
    (["--frontend", "udp://x", "--backend", "tcp://127.0.0.1:2"], "not an ipc://"),
])
def test_proxy_process_refuses_bad_arguments(args: list[str], message: str) -> None:
    out = subprocess.run([sys.executable, "-m", "mrss.bus.proxy", *args],
                         capture_output=True, text=True, timeout=30)
    assert out.returncode == 2
    assert message in out.stderr
