"""Data layer of the edge test project: a few external functions with known behaviour."""

from __future__ import annotations

import threading
from typing import Any

from mrss.actors.datalayer.layer import DataLayer, external
from mrss.errors import TransientError


class FixtureData(DataLayer):
    """External functions for the request/reply tests."""

    def __init__(self, *args: Any, **kwargs: Any) -> None:
        super().__init__(*args, **kwargs)
        self.release = threading.Event()

    @external()
    def add(self, a: float, b: float) -> float:
        return a + b

    @external("water_left")
    def water_left(self, robot: str) -> Any:
        return self.ground(robot)["attributes"].get("water", 0)

    @external()
    def explode(self) -> None:
        raise RuntimeError("the external service is down")

    @external()
    def world_away(self) -> None:
        raise TransientError("world model restarting")  # as a DataLayerUnavailable would

    @external()
    def hang(self) -> None:
        self.release.wait(10)

    @external()
    def not_plain(self) -> Any:
        return object()

    def stop(self) -> None:
        self.release.set()
