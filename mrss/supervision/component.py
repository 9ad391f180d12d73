"""The base class of every MRSS component process, and the context it starts with.

A component is started by the root supervisor as
`python -m mrss.supervision.component_main <module:Class> --name ID --inc N --context JSON`
(or forked from a pre-imported template). `start(ctx)` must set up the component's
threads or actors and return; the component is *ready* when it returns. `stop()` is
called once on SIGTERM and must return within the component's shutdown limit.
"""

from __future__ import annotations

import importlib
import json
import logging
import threading
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from mrss.errors import BusError, SupervisionError


@dataclass
class ComponentContext:
    """What a component knows at start: who it is, where it runs, how to reach the bus.

    `incarnation` goes up by one at every start of this component; messages it sends
    carry it (`inc`) so that a dead incarnation's late messages can be dropped.
    `bus` holds the endpoints as `mrss.bus.BusEndpoints.to_dict()` gives them.
    `options` are the component's free keys from project.toml.
    """

    name: str
    incarnation: int
    project_dir: Path
    run_dir: Path
    bus: dict[str, Any] = field(default_factory=dict)
    options: dict[str, Any] = field(default_factory=dict)
    heartbeat_interval: float = 0.5
    faults: dict[str, Any] = field(default_factory=dict)
    scheduling: dict[str, Any] = field(default_factory=dict)  # {"nice": n, "cpus": [...]}
    _failure: list[str] = field(default_factory=list, repr=False)
    _stop: threading.Event = field(default_factory=threading.Event, repr=False)
    _publisher: Any = field(default=None, repr=False)
    _publisher_lock: threading.Lock = field(default_factory=threading.Lock, repr=False,
                                            compare=False)

    @property
    def log(self) -> logging.Logger:
        """The component's logger, named for it."""
        return logging.getLogger(f"mrss.{self.name}")

    @property
    def publisher(self) -> Any:
        """A `mrss.bus.Publisher` for this component and incarnation, made on first use.

        Thread-safe: the runtime's log handler may be the first to use it, on its thread.
        """
        publisher = self._publisher
        if publisher is not None:
            return publisher
        with self._publisher_lock:
            return self._make_publisher()

    def _make_publisher(self) -> Any:
        if self._publisher is None:
            if not self.bus:
                raise BusError(f"component {self.name}: no bus endpoints configured")
            try:
                bus = importlib.import_module("mrss.bus")
            except ImportError as exc:
                raise BusError("the bus package mrss.bus is not available") from exc
            endpoints = bus.BusEndpoints.from_dict(self.bus)
            self._publisher = bus.Publisher(endpoints, src=self.name, inc=self.incarnation)
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

    def to_json(self) -> str:
        """The --context argument for component_main."""
        return json.dumps({
            "project_dir": str(self.project_dir), "run_dir": str(self.run_dir),
            "bus": self.bus, "options": self.options,
            "heartbeat_interval": self.heartbeat_interval, "faults": self.faults,
            "scheduling": self.scheduling,
        })

    @classmethod
    def from_json(cls, name: str, incarnation: int, text: str) -> ComponentContext:
        try:
            data = json.loads(text)
            return cls(
                name=name, incarnation=incarnation, project_dir=Path(data["project_dir"]),
                run_dir=Path(data["run_dir"]), bus=dict(data.get("bus") or {}),
                options=dict(data.get("options") or {}),
                heartbeat_interval=float(data.get("heartbeat_interval", 0.5)),
                faults=dict(data.get("faults") or {}),
                scheduling=dict(data.get("scheduling") or {}),
            )
        except (ValueError, KeyError, TypeError) as exc:
            raise SupervisionError(f"component {name}: bad --context: {exc}") from exc


class Component:
    """Base of component classes: override `start` and `stop` (and maybe `healthy`)."""

    def start(self, ctx: ComponentContext) -> None:
        """Set up and return; the component is ready when this returns."""

    def stop(self) -> None:
        """Release everything `start` set up; called once, on SIGTERM."""

    def healthy(self) -> bool:
        """Heartbeats are only sent while this is True; override to tie them to your loop."""
        return True
