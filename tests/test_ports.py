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
    _forget_ranges()
    monkeypatch.setattr(ports, "_RANGE_FILE", tmp_path / "missing")
    try:
        chosen = ports.free_ports(3)
        assert len(set(chosen)) == 3
        assert all(p in _ephemeral() for p in chosen)
        assert ports.shares(2) == []
    finally:
        _forget_ranges()


def _forget_ranges() -> None:
    ports._allowed.cache_clear()
    ports.outside_ephemeral.cache_clear()


def test_shares_are_disjoint_and_a_share_narrows_the_choice(
        monkeypatch: pytest.MonkeyPatch) -> None:
    first, second = ports.shares(2)
    spans = [tuple(int(n) for n in share.split("-")) for share in (first, second)]
    assert spans[0][1] < spans[1][0]  # disjoint, in order
    monkeypatch.setenv(ports.SHARE_VARIABLE, second)
    _forget_ranges()
    try:
        chosen = ports.free_ports(30)
        assert all(spans[1][0] <= p <= spans[1][1] for p in chosen)
        assert not any(p in _ephemeral() for p in chosen)
    finally:
        monkeypatch.undo()
        _forget_ranges()


def test_a_malformed_share_is_a_clear_error(monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setenv(ports.SHARE_VARIABLE, "10000:20000")
    _forget_ranges()
    try:
        with pytest.raises(ValueError, match="MRSS_PORTS='10000:20000': expected LOW-HIGH"):
            ports.free_port()
    finally:
        monkeypatch.undo()
        _forget_ranges()
