"""mrss.ports: ports chosen in advance stay clear of what the kernel hands out itself."""

from __future__ import annotations

import socket
from pathlib import Path

import pytest

from mrss import ports


def _ephemeral() -> range:
    low, high = (int(n) for n in Path("/proc/sys/net/ipv4/ip_local_port_range")
                 .read_text().split())
    return range(low, high + 1)


def test_ports_are_outside_the_ephemeral_range_distinct_free_and_never_twice() -> None:
    ephemeral = _ephemeral()
    tcp = ports.free_ports(20)
    udp = ports.free_ports(20, kind=socket.SOCK_DGRAM)
    for chosen, kind in ((tcp, socket.SOCK_STREAM), (udp, socket.SOCK_DGRAM)):
        assert len(set(chosen)) == 20
        assert not any(p in ephemeral for p in chosen)
        for port in chosen:
            with socket.socket(socket.AF_INET, kind) as s:
                s.bind(("127.0.0.1", port))  # free: it binds
    assert not set(tcp) & set(ports.free_ports(50))  # a process never gets one twice


def test_a_port_in_use_is_not_chosen(monkeypatch: pytest.MonkeyPatch) -> None:
    with socket.socket(socket.AF_INET, socket.SOCK_STREAM) as taken:
        taken.bind(("127.0.0.1", 0))
        taken.listen()
        port = taken.getsockname()[1]
        monkeypatch.setattr(ports, "_allowed", lambda: [port])
        chosen = ports.free_port()
        assert chosen != port  # not bindable there, so the kernel chose instead


def test_without_a_readable_range_the_kernel_chooses(monkeypatch: pytest.MonkeyPatch,
                                                     tmp_path: Path) -> None:
    ports._allowed.cache_clear()
    monkeypatch.setattr(ports, "_RANGE_FILE", tmp_path / "missing")
    try:
        chosen = ports.free_ports(3)
        assert len(set(chosen)) == 3
        assert all(p in _ephemeral() for p in chosen)
    finally:
        ports._allowed.cache_clear()
