"""The little of the bus that components use: publish, and subscribe by prefix.

Components receive a `BusPort`; `mrss.bus` (Publisher/Subscriber over the ZeroMQ proxy)
provides the real one, `ZmqBusPort`, through `bus_port(ctx)` below.
"""

from __future__ import annotations

import threading
from collections.abc import Callable, Sequence
from typing import Protocol

from mrss.bus import BusEndpoints, Subscriber
from mrss.messages import Envelope, Message
from mrss.runtime.component import ComponentContext

EnvelopeCallback = Callable[[Envelope], None]


class MessagePublisher(Protocol):
    """Publishes messages on the bus (`mrss.bus.Publisher` is one)."""

    def publish(self, msg: Message, topic: str | None = None) -> str: ...


class Subscription(Protocol):
    """A running subscription; `close()` stops delivery."""

    def close(self) -> None: ...


class BusPort(MessagePublisher, Protocol):
    """Publish, and deliver messages whose topic starts with a prefix to a callback."""

    def subscribe(self, prefixes: Sequence[str], callback: EnvelopeCallback) -> Subscription:
        ...

    def close(self) -> None:
        """Close every subscription made through this port."""
        ...


class ZmqBusPort:
    """A BusPort over `mrss.bus`: a Publisher, and one Subscriber per subscription."""

    def __init__(self, endpoints: BusEndpoints, publisher: MessagePublisher, name: str) -> None:
        self._endpoints = endpoints
        self._publisher = publisher
        self._name = name
        self._subs: list[Subscriber] = []
        self._lock = threading.Lock()

    @property
    def src(self) -> str:
        """The name this port's messages go out under (its Publisher's `src`)."""
        return str(getattr(self._publisher, "src", self._name))

    def publish(self, msg: Message, topic: str | None = None) -> str:
        return self._publisher.publish(msg, topic)

    def subscribe(self, prefixes: Sequence[str], callback: EnvelopeCallback,
                  ) -> Subscription:
        sub = Subscriber(self._endpoints, prefixes=list(prefixes),
                         name=f"{self._name}:{','.join(prefixes)}")
        sub.start(callback)
        with self._lock:
            self._subs.append(sub)
        return sub

    def wait_connected(self, timeout: float = 5.0) -> bool:
        """Whether every subscription has been greeted by the proxy."""
        with self._lock:
            subs = list(self._subs)
        return all(sub.wait_connected(timeout) for sub in subs)

    def close(self) -> None:
        with self._lock:
            subs, self._subs = self._subs, []
        for sub in subs:
            sub.close()


def bus_port(ctx: ComponentContext) -> ZmqBusPort:
    """The component's view of the bus: its Publisher and the endpoints in its context."""
    return ZmqBusPort(BusEndpoints.from_dict(ctx.bus), ctx.publisher, ctx.name)
