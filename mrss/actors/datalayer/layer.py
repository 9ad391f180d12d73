"""The base class of a project's datalayer.py: `DataLayer`, and what it is handed.

A data layer answers grounding requests and external function calls, and forwards robot
telemetry to the world model (paper IV-C):

    class Data(DataLayer):
        @external("distance")
        def distance(self, a: str, b: str) -> float: ...
"""

from __future__ import annotations

import inspect
import logging
from collections.abc import Callable, Mapping
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, TypeVar

from mrss.errors import ConfigError
from mrss.runtime.percepts import PerceptPublisher
from mrss.world.access import WorldModelAccess

__all__ = ["DataLayer", "DataLayerContext", "WorldModelAccess", "external"]


@dataclass
class DataLayerContext:
    """What the data layer component hands the project's DataLayer."""

    world: WorldModelAccess | None
    percept: PerceptPublisher | None = None
    options: Mapping[str, Any] = field(default_factory=dict)
    project_dir: Path | None = None
    log: logging.Logger = field(default_factory=lambda: logging.getLogger("mrss.datalayer"))


F = TypeVar("F", bound=Callable[..., Any])
_EXTERNAL_ATTR = "_mrss_external_name"
POSITION_KEYS = ("lat", "lon", "alt")


def external(name: str | None = None) -> Callable[[F], F]:
    """Mark a DataLayer method as an external function callable as `name` (default: its own)."""
    def mark(method: F) -> F:
        setattr(method, _EXTERNAL_ATTR, name or method.__name__)
        return method
    return mark


class DataLayer:
    """A project's symbol and data layer. The defaults ground ids from the world model.

    Built-in functions: `ping()`, `ground(id)`, `objects(kind)`, `near(lat, lon, radius_m,
    kind)`. A project adds its own with `@external`; a lookup that fails raises (the
    caller gets an error reply with the message).
    """

    def __init__(self, context: DataLayerContext) -> None:
        self.context = context
        self.options = context.options
        self.log = context.log

    @property
    def world(self) -> WorldModelAccess:
        """The world model; ConfigError when the deployment has none."""
        if self.context.world is None:
            raise ConfigError("no world model is configured", key="datalayer.world_model")
        return self.context.world

    def start(self) -> None:
        """Connect to external systems (called once before requests flow)."""

    def stop(self) -> None:
        """Release what `start` acquired."""

    def functions(self) -> dict[str, Callable[..., Any]]:
        """Every callable function by name: the built-ins and the `@external` methods."""
        table: dict[str, Callable[..., Any]] = {}
        for attr in dir(type(self)):
            raw = inspect.getattr_static(self, attr, None)
            name = getattr(raw, _EXTERNAL_ATTR, None)
            if isinstance(name, str):
                table[name] = getattr(self, attr)
        return table

    @external()
    def ping(self) -> str:
        """Liveness probe."""
        return "pong"

    @external()
    def ground(self, object_id: str) -> Any:
        """The data behind an object id (the world model object by default)."""
        if not isinstance(object_id, str):
            raise TypeError("object id must be a string")
        obj = self.world.get(object_id)
        if obj is None:
            raise LookupError(f"no object {object_id!r} in the world model")
        return obj

    @external()
    def objects(self, kind: str | None = None) -> list[dict[str, Any]]:
        """Every object of a kind (all objects without one)."""
        return self.world.objects(kind)

    @external()
    def near(self, lat: float, lon: float, radius_m: float,
             kind: str | None = None) -> list[dict[str, Any]]:
        """Objects within a radius of a point, nearest first."""
        return self.world.near(lat, lon, radius_m, kind)

    def on_telemetry(self, robot: str, data: Mapping[str, Any]) -> None:
        """Robot telemetry: by default the robot's world model object is updated with it.

        `lat`/`lon`/`alt` become its position; everything else merges into attributes.
        With the embedded world model the write is not waited for (writes stay in order).
        """
        if self.context.world is None:
            return
        obj: dict[str, Any] = {"id": robot, "kind": "robot",
                               "attributes": {k: v for k, v in data.items()
                                              if k not in POSITION_KEYS}}
        if "lat" in data and "lon" in data:
            obj["position"] = {k: data[k] for k in POSITION_KEYS if k in data}
        # Over the bus the write is sent without waiting for its answer: telemetry needs
        # none, and a round trip per record would cap a fleet's telemetry rate.
        write = getattr(self.world, "upsert_nowait", None) or self.world.upsert
        write(obj)
