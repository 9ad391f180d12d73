"""What the edge components need from their component context, and their bus port.

The root supervisor starts each component with a context (name, incarnation, project
folder, run folder, bus endpoints, a Publisher, the project's configuration);
`ComponentContext` names the part of it the edge components read. `bus_port(ctx)`
wraps the context's Publisher and the bus endpoints into a `BusPort`.
"""

from __future__ import annotations

import importlib
import threading
from collections.abc import Mapping, Sequence
from pathlib import Path
from typing import Any, Protocol

from mrss.edge.busport import BusPort, EnvelopeCallback, MessagePublisher, Subscription
from mrss.errors import ConfigError
from mrss.messages import Message


class ComponentContext(Protocol):
    """The fields of the supervisor's component context used here."""

    @property
    def name(self) -> str: ...

    @property
    def incarnation(self) -> int: ...

    @property
    def project_dir(self) -> Path: ...

    @property
    def run_dir(self) -> Path: ...

    @property
    def options(self) -> Mapping[str, Any]: ...

    @property
    def publisher(self) -> MessagePublisher: ...

    @property
    def endpoints(self) -> Any: ...


def table(config: Mapping[str, Any], name: str) -> Mapping[str, Any]:
    """The `[name]` table of a project configuration ({} when absent)."""
    value = config.get(name, {})
    if not isinstance(value, Mapping):
        raise ConfigError(f"[{name}] must be a table", key=name)
    return value


class ZmqBusPort:
    """A BusPort over `mrss.bus`: the context's Publisher, one Subscriber per subscription."""

    def __init__(self, endpoints: Any, publisher: MessagePublisher, name: str) -> None:
        self._bus = importlib.import_module("mrss.bus")
        self._endpoints = endpoints
        self._publisher = publisher
        self._name = name
        self._subs: list[Any] = []
        self._lock = threading.Lock()

    def publish(self, msg: Message, topic: str | None = None) -> str:
        return self._publisher.publish(msg, topic)

    def subscribe(self, prefixes: Sequence[str], callback: EnvelopeCallback) -> Subscription:
        sub = self._bus.Subscriber(self._endpoints, prefixes=list(prefixes),
                                   name=f"{self._name}:{','.join(prefixes)}")
        sub.start(callback)
        with self._lock:
            self._subs.append(sub)
        return sub  # type: ignore[no-any-return]

    def close(self) -> None:
        with self._lock:
            subs, self._subs = self._subs, []
        for sub in subs:
            sub.close()


def bus_port(ctx: ComponentContext) -> BusPort:
    """The component's view of the bus."""
    return ZmqBusPort(ctx.endpoints, ctx.publisher, ctx.name)
