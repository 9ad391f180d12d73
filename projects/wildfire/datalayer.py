"""Symbol and Data Layer of the wildfire project (paper IV-C).

Telemetry from the RCL's links (`robot.<id>.data`, one record per message, see
docs/robots.md) is grounded into the world model and into symbols:

- `position`, `status` records update the robot's object (position and attributes);
- `battery` below `battery_low` % perceives `battery_low(R)`; the percept is removed
  once the battery is back above `battery_ok` % (hysteresis: one event per low spell);
- `tank` below `water_low` % of capacity perceives `water_low(R)`, removed above `water_ok`;
- `hotspot` (the UAV's thermal camera) becomes a world model object `hs<N>` of kind
  `hotspot` (no `state` attribute yet: new); the world model's rule decides whether it
  is `hotspot_detected`;
- `supply` (the UGV's SupplyWater skill: `target`, `state` supplying / supplied / new)
  sets that hotspot's `state` (the dashboard's map colours hotspots by it).

External function for the RCL: `area_polygon(goal)` -> the area's [[lat, lon], ...]
(a circle area comes back as a 24-gon).
"""

from __future__ import annotations

import math
import threading
from collections.abc import Mapping
from typing import Any

from mrss.api import Atom, Check, DataLayer, Option, external, offset

CIRCLE_VERTICES = 24
HOTSPOT_STATES = ("new", "supplying", "supplied")  # project.toml [map] colours them


def circle(lat: float, lon: float, radius_m: float) -> list[list[float]]:
    """A polygon of CIRCLE_VERTICES vertices approximating a circle."""
    points = []
    for i in range(CIRCLE_VERTICES):
        angle = 2 * math.pi * i / CIRCLE_VERTICES
        p_lat, p_lon = offset(lat, lon, radius_m * math.cos(angle), radius_m * math.sin(angle))
        points.append([p_lat, p_lon])
    return points


class WildfireData(DataLayer):
    """Telemetry -> world model and threshold percepts; areas -> polygons."""

    #: What this data layer reads from [datalayer] (checked by `mrss check`).
    OPTIONS = (
        Option("battery_low", float, 30.0, "% below which battery_low(R) is perceived",
               Check.NON_NEGATIVE),
        Option("battery_ok", float, 90.0, "% above which battery_low(R) is removed",
               Check.NON_NEGATIVE),
        Option("water_low", float, 25.0, "% of the tank below which water_low(R) is perceived",
               Check.NON_NEGATIVE),
        Option("water_ok", float, 95.0, "% of the tank above which water_low(R) is removed",
               Check.NON_NEGATIVE),
    )

    def start(self) -> None:
        self.battery_low = float(self.options.get("battery_low", 30.0))
        self.battery_ok = float(self.options.get("battery_ok", 90.0))
        self.water_low = float(self.options.get("water_low", 25.0))
        self.water_ok = float(self.options.get("water_ok", 95.0))
        self._low: dict[tuple[str, str], bool] = {}  # (robot, functor) -> perceived now
        self._lock = threading.Lock()

    @external("area_polygon")
    def area_polygon(self, goal: str) -> list[list[float]]:
        """The polygon of area `goal` from the world model."""
        area = self.ground(goal)
        attrs = area.get("attributes", {})
        if "polygon" in attrs:
            return [[float(p[0]), float(p[1])] for p in attrs["polygon"]]
        center = area.get("position") or {}
        if "radius_m" in attrs and "lat" in center:
            return circle(float(center["lat"]), float(center["lon"]), float(attrs["radius_m"]))
        raise LookupError(f"{goal!r} is not an area with a polygon or a radius")

    def on_telemetry(self, robot: str, data: Mapping[str, Any]) -> None:
        kind = data.get("type")
        if kind == "position":
            self._update(robot, data, ("heading", "speed", "relative_alt"))
        elif kind == "status":
            self._update(robot, data, ("mode", "armed", "landed", "at_base", "teleop"))
        elif kind == "battery":
            remaining = data.get("remaining")
            if isinstance(remaining, (int, float)):
                self._update(robot, {"battery": remaining}, ("battery",))
                self._threshold(robot, "battery_low", remaining, self.battery_low,
                                self.battery_ok)
        elif kind == "tank":
            level, capacity = data.get("level"), data.get("capacity")
            if isinstance(level, (int, float)) and isinstance(capacity, (int, float)) \
                    and capacity > 0:
                self._update(robot, {"water": level, "tank": capacity}, ("water", "tank"))
                self._threshold(robot, "water_low", 100.0 * level / capacity, self.water_low,
                                self.water_ok)
        elif kind == "hotspot":
            self._hotspot(robot, data)
        elif kind == "supply":
            self._supply(data)

    def _update(self, robot: str, data: Mapping[str, Any], keys: tuple[str, ...]) -> None:
        obj: dict[str, Any] = {"id": robot, "kind": "robot",
                               "attributes": {k: data[k] for k in keys if k in data}}
        if "lat" in data and "lon" in data:
            obj["position"] = {"lat": data["lat"], "lon": data["lon"]}
        self.world.upsert(obj)

    def _threshold(self, robot: str, functor: str, value: float, low: float,
                   ok: float) -> None:
        """Perceive `functor(robot)` when `value` drops below `low`, forget it above `ok`."""
        key = (robot, functor)
        with self._lock:
            was = self._low.get(key, False)
            now = value < low or (was and value < ok)
            self._low[key] = now
        if now and not was:
            self.log.info("%s: %s (%.0f%%)", robot, functor, value)
            self._percept(functor, robot, "add")
        elif was and not now:
            self._percept(functor, robot, "remove")

    def _percept(self, functor: str, robot: str, op: str) -> None:
        if self.context.percept is not None:
            self.context.percept(functor, Atom(robot), op=op)

    def _hotspot(self, robot: str, data: Mapping[str, Any]) -> None:
        ident = data.get("id")
        if not isinstance(ident, int):
            return
        hotspot = {"id": f"hs{ident}", "kind": "hotspot",
                   "position": {"lat": data["lat"], "lon": data["lon"]},
                   "attributes": {"temperature": data.get("temperature"), "seen_by": robot}}
        result = self.world.upsert(hotspot)
        self.log.info("hotspot hs%d at %.6f,%.6f reported by %s (%s)", ident, data["lat"],
                      data["lon"], robot, result.get("op", "?") if isinstance(result, dict)
                      else "?")

    def _supply(self, data: Mapping[str, Any]) -> None:
        target, state = data.get("target"), data.get("state")
        if state not in HOTSPOT_STATES or not isinstance(target, str):
            return
        found = self.world.get(target)
        if found is None or found.get("kind") != "hotspot":
            return
        self.world.upsert({"id": target, "kind": "hotspot", "attributes": {"state": state}})
