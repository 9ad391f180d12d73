"""The bus proxy as a supervised component: the first child of every project's tree."""

from __future__ import annotations

from typing import ClassVar

from mrss.bus.endpoints import BusEndpoints
from mrss.bus.mesh import MeshSettings, MeshThread
from mrss.bus.proxy import ProxyThread
from mrss.config.loader import Option
from mrss.errors import ConfigError
from mrss.runtime.component import Component, ComponentContext


class ProxyComponent(Component):
    """Runs the XSUB/XPUB proxy on the endpoints the supervisor hands every component; on
    a node of several (`mrss supervise --node`, which passes `options["mesh"]`), the
    node's proxy with its CurveZMQ links to the other nodes (mrss.bus.mesh)."""

    #: The options this component reads (`mrss check` validates them; docs/config.md).
    OPTIONS: ClassVar[tuple[Option, ...]] = ()

    def __init__(self) -> None:
        self._proxy: ProxyThread | MeshThread | None = None

    def start(self, ctx: ComponentContext) -> None:
        if not ctx.bus:
            raise ConfigError("the bus component needs bus endpoints", key="bus")
        endpoints = BusEndpoints.from_dict(ctx.bus)
        mesh = ctx.options.get("mesh")
        if mesh is None:  # the first incarnation of a run: no clients to wait for
            self._proxy = ProxyThread(endpoints, fresh=ctx.incarnation <= 1).start()
        else:
            self._proxy = MeshThread(endpoints, MeshSettings.from_dict(mesh)).start()

    def healthy(self) -> bool:
        return not isinstance(self._proxy, MeshThread) or self._proxy.alive()

    def stop(self) -> None:
        if self._proxy is not None:
            self._proxy.stop()
