"""Where the bus proxy listens: its frontend (publishers connect) and backend (subscribers)."""

from __future__ import annotations

import ipaddress
import os
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from mrss.errors import ConfigError
from mrss.messages import IncarnationKey, load_key
from mrss.ports import free_ports

# sockaddr_un.sun_path holds 108 bytes including the terminating NUL.
_MAX_IPC_PATH = 107
_SCHEMES = ("ipc://", "tcp://", "inproc://")
_LOOPBACK = ("127.0.0.1", "localhost", "[::1]")


@dataclass(frozen=True)
class BusEndpoints:
    """The two ZeroMQ endpoints of one bus.

    `frontend` is where the proxy's XSUB binds and every publisher connects; `backend`
    is where its XPUB binds and every subscriber connects. Both are validated on
    construction: ipc paths must fit a unix socket address, tcp needs a host and port.
    `key` is the path of the run's incarnation key (mrss/messages/credentials.py), set by
    the root supervisor for the components it starts: their publishers then prove their
    incarnation, and their receivers believe only proven ones ("": a bus without one).
    """

    frontend: str
    backend: str
    direct: bool = False  # deliver directly, the proxy only introducing (mrss/bus/direct.py)
    key: str = ""

    def authority(self) -> IncarnationKey | None:
        """The run's incarnation key (None on a bus without one); BusError if unreadable."""
        return load_key(self.key) if self.key else None

    def credential(self, src: str, inc: int) -> bytes:
        """The proof of incarnation `inc` of `src` its envelopes carry (b"": none)."""
        key = self.authority()
        return key.credential(src, inc) if key is not None and inc > 0 else b""

    def keyed(self, key: str | os.PathLike[str]) -> BusEndpoints:
        """These endpoints with the run's incarnation key at `key`."""
        return BusEndpoints(self.frontend, self.backend, self.direct, str(key))

    def __post_init__(self) -> None:
        for key in ("frontend", "backend"):
            _check_endpoint(getattr(self, key), key)
        if self.frontend == self.backend:
            raise ConfigError("frontend and backend must differ", key="bus")
        if self.direct and self.backend.startswith("tcp://") and \
                self.backend[len("tcp://"):].rpartition(":")[0] not in _LOOPBACK:
            raise ConfigError("direct delivery is for one host: use ipc, or tcp on "
                              "127.0.0.1", key="bus.delivery")

    @classmethod
    def ipc(cls, run_dir: str | os.PathLike[str], *, direct: bool = False) -> BusEndpoints:
        """Unix sockets `bus-pub.sock` and `bus-sub.sock` in `run_dir` (the default)."""
        base = Path(run_dir).absolute()
        return cls(f"ipc://{base / 'bus-pub.sock'}", f"ipc://{base / 'bus-sub.sock'}", direct)

    @classmethod
    def tcp(cls, host: str, pub_port: int, sub_port: int, *, direct: bool = False
            ) -> BusEndpoints:
        """TCP on `host` (configure 127.0.0.1 unless other hosts must connect)."""
        return cls(f"tcp://{host}:{pub_port}", f"tcp://{host}:{sub_port}", direct)

    @classmethod
    def tcp_loopback(cls, *, direct: bool = False) -> BusEndpoints:
        """TCP on 127.0.0.1 with two ports free right now (for tests and benchmarks)."""
        return cls.tcp("127.0.0.1", *free_ports(2), direct=direct)

    def to_dict(self) -> dict[str, Any]:
        """A plain map, e.g. for a child process's command line or context."""
        plain: dict[str, Any] = {"frontend": self.frontend, "backend": self.backend}
        if self.direct:
            plain["direct"] = True
        if self.key:
            plain["key"] = self.key
        return plain

    @classmethod
    def from_dict(cls, data: dict[str, Any]) -> BusEndpoints:
        """The inverse of `to_dict`; ConfigError names the bad key."""
        if not isinstance(data, dict):
            raise ConfigError("bus endpoints must be a map with frontend and backend", key="bus")
        for key in ("frontend", "backend"):
            if not isinstance(data.get(key), str):
                raise ConfigError("missing or not a string", key=f"bus.{key}")
        extra = sorted(set(data) - {"frontend", "backend", "direct", "key"})
        if extra:
            raise ConfigError(f"unknown key(s) {extra}", key="bus")
        direct = data.get("direct", False)
        if not isinstance(direct, bool):
            raise ConfigError("must be true or false", key="bus.direct")
        key = data.get("key", "")
        if not isinstance(key, str):
            raise ConfigError("must be the path of the incarnation key", key="bus.key")
        return cls(data["frontend"], data["backend"], direct, key)

    def ipc_paths(self) -> list[Path]:
        """The socket files of ipc endpoints (empty for tcp)."""
        return self.paths_of([self.frontend, self.backend])

    @staticmethod
    def paths_of(endpoints: list[str]) -> list[Path]:
        """The socket files of those of `endpoints` that are ipc."""
        return [Path(ep[len("ipc://"):]) for ep in endpoints if ep.startswith("ipc://")]


def _check_endpoint(endpoint: str, key: str) -> None:
    if not isinstance(endpoint, str) or not endpoint.startswith(_SCHEMES):
        raise ConfigError(f"{endpoint!r} is not an ipc://, tcp:// or inproc:// endpoint",
                          key=f"bus.{key}")
    if endpoint.startswith("ipc://"):
        path = endpoint[len("ipc://"):]
        if not path.startswith("/"):
            raise ConfigError(f"ipc path {path!r} must be absolute", key=f"bus.{key}")
        if len(path.encode()) > _MAX_IPC_PATH:
            raise ConfigError(
                f"ipc path is {len(path.encode())} bytes, longer than a unix socket allows "
                f"({_MAX_IPC_PATH}); use a shorter run directory", key=f"bus.{key}")
    elif endpoint.startswith("tcp://"):
        host, sep, port = endpoint[len("tcp://"):].rpartition(":")
        if not sep or not host or not port.isdigit() or not 0 < int(port) < 65536:
            raise ConfigError(f"{endpoint!r} needs tcp://HOST:PORT with a port 1-65535",
                              key=f"bus.{key}")
        if host != "localhost" and host != "*":
            try:
                ipaddress.ip_address(host.strip("[]"))
            except ValueError:
                raise ConfigError(f"{host!r} is not an IP address", key=f"bus.{key}") from None
