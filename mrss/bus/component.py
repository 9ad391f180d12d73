"""The bus proxy as a supervised component: the first child of every project's tree."""

from __future__ import annotations

from typing import Any, ClassVar

from mrss.bus.endpoints import BusEndpoints
from mrss.bus.proxy import ProxyThread
from mrss.config import Check, Option
from mrss.errors import ConfigError
from mrss.supervision.component import Component, ComponentContext


class ProxyComponent(Component):
    """Runs the XSUB/XPUB proxy on the endpoints the supervisor hands every component."""

    #: The options this component reads (`mrss check` validates them; docs/config.md).
    OPTIONS: ClassVar[tuple[Option, ...]] = ()

    def __init__(self) -> None:
        self._proxy: ProxyThread | None = None

    def start(self, ctx: ComponentContext) -> None:
        if not ctx.bus:
            raise ConfigError("the bus component needs bus endpoints", key="bus")
        self._proxy = ProxyThread(BusEndpoints.from_dict(ctx.bus)).start()

    def stop(self) -> None:
        if self._proxy is not None:
            self._proxy.stop()


#: The keys of `[bus]` (read by endpoints_from_config; `mrss check` validates them).
BUS_OPTIONS: tuple[Option, ...] = (
    Option("transport", str, "ipc", "ipc: sockets in the run folder; tcp: host and ports",
           choices=("ipc", "tcp")),
    Option("host", str, "127.0.0.1", "tcp: the proxy's address"),
    Option("frontend_port", int, None, "tcp: the port publishers connect to", Check.PORT),
    Option("backend_port", int, None, "tcp: the port subscribers connect to", Check.PORT),
)


def endpoints_from_config(section: dict[str, Any], run_dir: Any, *, file: str = ""
                          ) -> BusEndpoints:
    """The `[bus]` table: `transport = "ipc"` (default, sockets in the run directory) or
    `"tcp"` with `host` (default 127.0.0.1), `frontend_port`, `backend_port`."""
    transport = section.get("transport", "ipc")
    if transport == "ipc":
        return BusEndpoints.ipc(run_dir)
    if transport != "tcp":
        raise ConfigError(f"must be 'ipc' or 'tcp', not {transport!r}", file=file,
                          key="bus.transport")
    host = section.get("host", "127.0.0.1")
    ports = []
    for key in ("frontend_port", "backend_port"):
        port = section.get(key)
        if not isinstance(port, int) or isinstance(port, bool) or not 0 < port < 65536:
            raise ConfigError(f"must be a port number, not {port!r}", file=file,
                              key=f"bus.{key}")
        ports.append(port)
    if not isinstance(host, str) or not host:
        raise ConfigError("must be a host name or address", file=file, key="bus.host")
    return BusEndpoints.tcp(host, ports[0], ports[1])
