"""The base class of every MRSS component process, and the context it starts with.

A component is started by the root supervisor as
`python -m mrss.runtime.main <module:Class> --name ID --inc N --context JSON`
(or forked from a pre-imported template). `start(ctx)` must set up the component's
threads or actors and return; the component is *ready* when it returns. `stop()` is
called once on SIGTERM and must return within the component's shutdown limit.
"""

from __future__ import annotations

import logging
import threading
from dataclasses import dataclass, field

from mrss.bus import BusEndpoints, Publisher
from mrss.errors import BusError
from mrss.supervision.start import StartContext


@dataclass
class ComponentContext(StartContext):
    """The start context as a running component uses it: its logger, its bus publisher,
    and the way to end its incarnation (`fail`, `finish`)."""

    _failure: list[str] = field(default_factory=list, repr=False)
    _stop: threading.Event = field(default_factory=threading.Event, repr=False)
    _publisher: Publisher | None = field(default=None, repr=False)
    _publisher_lock: threading.Lock = field(default_factory=threading.Lock, repr=False,
                                            compare=False)

    @property
    def log(self) -> logging.Logger:
        """The component's logger, named for it."""
        return logging.getLogger(f"mrss.{self.name}")

    @property
    def publisher(self) -> Publisher:
        """A `mrss.bus.Publisher` for this component and incarnation, made on first use.

        Thread-safe: the runtime's log handler may be the first to use it, on its thread.
        """
        publisher = self._publisher
        if publisher is not None:
            return publisher
        with self._publisher_lock:
            return self._make_publisher()

    def _make_publisher(self) -> Publisher:
        if self._publisher is None:
            if not self.bus:
                raise BusError(f"component {self.name}: no bus endpoints configured")
            endpoints = BusEndpoints.from_dict(self.bus)
            self._publisher = Publisher(endpoints, src=self.name, inc=self.incarnation)
            # A fresh publisher's first messages would be lost until the proxy has
            # subscribed to it (slow joiner); give a running proxy the time to do so.
            self._publisher.wait_connected(timeout=2.0)
        return self._publisher

    def fail(self, reason: str) -> None:
        """Ask to end this incarnation as a failure (the supervisor applies its policy)."""
        self._failure.append(reason)
        self._stop.set()

    def finish(self) -> None:
        """End this incarnation normally (exit code 0): its work is done."""
        self._stop.set()

    def stop_requested(self) -> bool:
        return self._stop.is_set()


class Component:
    """Base of component classes: override `start` and `stop` (and maybe `healthy`)."""

    def start(self, ctx: ComponentContext) -> None:
        """Set up and return; the component is ready when this returns."""

    def stop(self) -> None:
        """Release everything `start` set up; called once, on SIGTERM."""

    def healthy(self) -> bool:
        """Heartbeats are only sent while this is True; override to tie them to your loop."""
        return True
