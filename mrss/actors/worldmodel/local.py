"""A world model in the same process, reached as the data layer reaches any other.

For tests and benchmarks (`mrss.api.testing`): it satisfies
`mrss.world.access.WorldModelAccess` over a `WorldModel` held here.
"""

from __future__ import annotations

from typing import Any

from mrss.actors.worldmodel.model import WorldModel
from mrss.world.objects import Position, WorldObject


class LocalWorldModel:
    """A `WorldModel` in this process."""

    def __init__(self, world: WorldModel) -> None:
        self.world = world

    def get(self, object_id: str) -> dict[str, Any] | None:
        obj = self.world.get(object_id)
        return None if obj is None else obj.to_json()

    def objects(self, kind: str | None = None) -> list[dict[str, Any]]:
        return [o.to_json() for o in self.world.objects(kind)]

    def upsert(self, obj: dict[str, Any]) -> dict[str, Any]:
        change = self.world.upsert(WorldObject.from_json(obj))
        return {"op": change.op, "object": change.obj.to_json()}

    def near(self, lat: float, lon: float, radius_m: float,
             kind: str | None = None) -> list[dict[str, Any]]:
        return [{**o.to_json(), "distance_m": d}
                for o, d in self.world.near(Position(lat, lon), radius_m, kind)]

    def intersecting(self, geometry: dict[str, Any],
                     kind: str | None = None) -> list[dict[str, Any]]:
        """Objects sharing a point with a GeoJSON geometry."""
        return list(self.world.call("wm.intersecting", [geometry, kind]))

    def within(self, geometry: dict[str, Any], kind: str | None = None) -> list[dict[str, Any]]:
        """Objects inside a GeoJSON geometry."""
        return list(self.world.call("wm.within", [geometry, kind]))

    def within_distance(self, geometry: dict[str, Any], distance_m: float,
                        kind: str | None = None) -> list[dict[str, Any]]:
        """Objects within `distance_m` of a GeoJSON geometry, nearest first."""
        return list(self.world.call("wm.within_distance", [geometry, distance_m, kind]))
