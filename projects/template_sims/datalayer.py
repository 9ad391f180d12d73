"""Symbol and Data Layer (paper IV-C, Table I "Data Layer"): grounding, functions, telemetry.

ADAPT: the data behind the agent's symbols and the robots' telemetry.
- `@external("name")` methods are callable by the reasoner (`query(name, [Args], R)`)
  and by the RCL (`self.data_call("name", ...)` in rcl.py); built in: `ping`, `ground(id)`
  (the world model object), `objects(kind)`, `near(lat, lon, radius_m, kind)`;
- `on_telemetry(robot, record)` gets every record rcl.py publishes with `publish_data`;
  the default stores it on the robot's world model object;
- `self.world` is the world model, `self.context.percept(...)` publishes percepts,
  `self.options` is the `[datalayer]` table of project.toml.
Delete this file to use the default DataLayer.
"""

from __future__ import annotations

from collections.abc import Mapping
from typing import Any

from mrss.api import DataLayer, distance_m, external


class ProjectData(DataLayer):
    """ADAPT: the project's data layer (exactly one DataLayer subclass here)."""

    @external("distance_to")
    def distance_to(self, object_id: str, lat: float, lon: float) -> float:
        """Metres from a world model object to a point (an example external function)."""
        position = self.ground(object_id).get("position") or {}
        if "lat" not in position:
            raise LookupError(f"{object_id!r} has no position")
        return distance_m(position["lat"], position["lon"], lat, lon)

    def on_telemetry(self, robot: str, data: Mapping[str, Any]) -> None:
        """ADAPT: ground telemetry; here the default (robot object, position + attributes)."""
        super().on_telemetry(robot, data)
