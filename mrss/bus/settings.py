"""The `[bus]` table of project.toml: the endpoints every component is handed.

`transport = "ipc"` (sockets in the run folder) or `"tcp"` (host and ports);
`delivery = "proxy"` (the default: every message through the proxy; what a project on
`[nodes]` runs) or `"direct"` (one host, mrss/bus/direct.py); the keys of several nodes.
"""

from __future__ import annotations

from typing import Any

from mrss.bus.endpoints import BusEndpoints
from mrss.errors import ConfigError
from mrss.options import Check, Option

#: The keys of `[bus]` (read by endpoints_from_config; `mrss check` validates them).
BUS_OPTIONS: tuple[Option, ...] = (
    Option("transport", str, "ipc", "ipc: sockets in the run folder; tcp: host and ports",
           choices=("ipc", "tcp")),
    Option("host", str, "127.0.0.1", "tcp: the proxy's address"),
    Option("delivery", str, "proxy", "proxy: every message through the proxy; direct: "
           "publisher to subscriber, the proxy only introduces (one host)",
           choices=("proxy", "direct")),
    Option("frontend_port", int, None, "tcp: the port publishers connect to", Check.PORT),
    Option("backend_port", int, None, "tcp: the port subscribers connect to", Check.PORT),
    Option("keys_dir", str, "keys", "[nodes]: the folder of the nodes' CurveZMQ keys "
           "(`mrss keys`), relative to the project"),
    Option("node_heartbeat", float, 0.5, "[nodes]: seconds between heartbeats to each peer",
           Check.POSITIVE),
    Option("node_misses", int, 4, "[nodes]: a peer silent this many heartbeats is lost",
           Check.POSITIVE),
    Option("max_clock_skew", float, 5.0, "[nodes]: a peer whose clock is further off is "
           "refused (seconds)", Check.POSITIVE),
)


_DELIVERY = next(option for option in BUS_OPTIONS if option.name == "delivery")


def endpoints_from_config(section: dict[str, Any], run_dir: Any, *, file: str = "",
                          nodes: bool = False) -> BusEndpoints:
    """The `[bus]` table: `transport = "ipc"` (default, sockets in the run directory) or
    `"tcp"` with `host` (default 127.0.0.1), `frontend_port`, `backend_port`; `delivery`
    `"proxy"` (the declared default) or `"direct"` (mrss/bus/direct.py). `nodes`: the
    project runs on `[nodes]`, whose proxies link the hosts: delivery through them unless
    the table says otherwise (`mrss supervise --node` refuses `"direct"` there), whatever
    the declared default."""
    transport = section.get("transport", "ipc")
    delivery = section.get("delivery", "proxy" if nodes else _DELIVERY.default)
    if delivery not in _DELIVERY.choices:
        raise ConfigError(f"must be 'proxy' or 'direct', not {delivery!r}", file=file,
                          key="bus.delivery")
    direct = delivery == "direct"
    if transport == "ipc":
        return BusEndpoints.ipc(run_dir, direct=direct)
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
    try:
        return BusEndpoints.tcp(host, ports[0], ports[1], direct=direct)
    except ConfigError as exc:
        raise ConfigError(exc.reason, file=file, key=exc.key) from None
