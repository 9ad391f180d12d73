"""The little of the bus that the edge components use: publish, and subscribe by prefix.

Components receive a `BusPort`; `mrss.bus` (Publisher/Subscriber over the ZeroMQ proxy)
provides the real one through `bus_port(ctx)` in `mrss.edge.component`.
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from typing import Protocol

from mrss.messages import Envelope, Message

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
