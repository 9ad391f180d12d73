"""Bus endpoints: defaults, validation, passing them to child processes."""

from __future__ import annotations

from pathlib import Path

import pytest

from mrss.bus import BusEndpoints
from mrss.errors import ConfigError


def test_ipc_endpoints_live_in_the_run_directory(tmp_path: Path) -> None:
    ep = BusEndpoints.ipc(tmp_path)
    assert ep.frontend == f"ipc://{tmp_path}/bus-pub.sock"
    assert ep.backend == f"ipc://{tmp_path}/bus-sub.sock"
    assert ep.ipc_paths() == [tmp_path / "bus-pub.sock", tmp_path / "bus-sub.sock"]


def test_endpoints_survive_the_trip_to_a_child_process(tmp_path: Path) -> None:
    for ep in (BusEndpoints.ipc(tmp_path), BusEndpoints.tcp("127.0.0.1", 5001, 5002)):
        assert BusEndpoints.from_dict(ep.to_dict()) == ep


def test_tcp_loopback_picks_two_free_ports_on_127_0_0_1() -> None:
    ep = BusEndpoints.tcp_loopback()
    assert ep.frontend.startswith("tcp://127.0.0.1:")
    assert ep.backend.startswith("tcp://127.0.0.1:")
    assert ep.frontend != ep.backend
    assert ep.ipc_paths() == []


@pytest.mark.parametrize(("frontend", "backend", "reason"), [
    ("ipc://relative/bus.sock", "ipc:///tmp/b.sock", "must be absolute"),
    ("ipc:///" + "x" * 120, "ipc:///tmp/b.sock", "longer than a unix socket allows"),
    ("tcp://127.0.0.1", "tcp://127.0.0.1:2", "tcp://HOST:PORT"),
    ("tcp://127.0.0.1:0", "tcp://127.0.0.1:2", "port 1-65535"),
    ("tcp://127.0.0.1:70000", "tcp://127.0.0.1:2", "port 1-65535"),
    ("tcp://my-host:1", "tcp://127.0.0.1:2", "not an IP address"),
    ("udp://127.0.0.1:1", "tcp://127.0.0.1:2", "not an ipc://, tcp://"),
    ("tcp://127.0.0.1:1", "tcp://127.0.0.1:1", "must differ"),
])
def test_bad_endpoints_are_refused_with_the_reason(frontend: str, backend: str,
                                                   reason: str) -> None:
    with pytest.raises(ConfigError, match=reason):
        BusEndpoints(frontend, backend)


@pytest.mark.parametrize(("data", "key"), [
    ({"frontend": "tcp://127.0.0.1:1"}, "bus.backend"),
    ({"frontend": 1, "backend": "tcp://127.0.0.1:2"}, "bus.frontend"),
    ({"frontend": "tcp://127.0.0.1:1", "backend": "tcp://127.0.0.1:2", "x": 1}, "bus"),
    (["tcp://127.0.0.1:1"], "bus"),
])
def test_from_dict_names_the_bad_key(data: object, key: str) -> None:
    with pytest.raises(ConfigError) as info:
        BusEndpoints.from_dict(data)  # type: ignore[arg-type]
    assert info.value.key == key
