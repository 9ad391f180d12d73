"""Operator events of the wildfire project (paper IV-B): MQTT JSON -> percepts.

Topics (prefix `[events] topic_prefix`, default "mrss/ui"), payloads are JSON objects,
each may carry an `"id"` (a string naming this message: a repeat with the same id is
not a second event):

    <prefix>/area      {"goal": "a1", "priority": 2, "polygon": [[lat, lon], ...]}
                       or {"goal": "a1", "center": [lat, lon] | {"lat", "lon"}, "radius": m}
                       -> the area goes into the world model, then area_goal_received(a1, 2)
                          (priority defaults to 1)
    <prefix>/cancel    {"goal": "a1"}                  -> goal_cancelled(a1)
    <prefix>/priority  {"goal": "a1", "priority": 5}   -> prioritychange(a1, 5)
    <prefix>/teleop    {"robot": "ugv1", "on": true}   -> teleop(ugv1, on), and teleop(ugv1, off)
                                                          is removed (or the reverse)
    <prefix>/hold      {"on": true}                    -> hold_all (all robots hold); false
                                                          removes it (they go on)

Goal ids and robot ids are lowercase identifiers, and a robot is one of the project's
(`self.robots`: the RCL's robots); a payload that does not fit is counted as bad and
reported back at once on `<topic>/reply`, never a percept. An area
waits for the world model while it is down (restarting, hung): the events manager tries
again with backoff, and reports `failed` on `<topic>/reply` if it stays down past
`[events] retry_budget`.
"""

from __future__ import annotations

from typing import Any

from mrss.api import (
    Atom,
    ExternalAdapter,
    Field,
    JsonMapping,
    Option,
    PayloadError,
    WorldModelClient,
)

GOAL = Field("goal", "atom")
PRIORITY = Field("priority", "int", default=1)
CANCEL = JsonMapping("goal_cancelled", GOAL)
PRIORITY_CHANGE = JsonMapping("prioritychange", GOAL, Field("priority", "int"))
TELEOP = JsonMapping("teleop", Field("robot", "robot"), Field("on", "bool"))
AREA = JsonMapping("area_goal_received", GOAL, PRIORITY)
HOLD_ON = Field("on", "bool")  # ops/hold: hold_all added (true) or removed (false)
MAX_VERTICES = 200
MAX_RADIUS_M = 5000.0


def _point(value: Any, what: str) -> list[float]:
    """[lat, lon] from [lat, lon] or {"lat", "lon"}; ValueError otherwise."""
    if isinstance(value, dict):
        value = [value.get("lat"), value.get("lon")]
    if (not isinstance(value, list) or len(value) != 2
            or not all(isinstance(v, (int, float)) and not isinstance(v, bool) for v in value)):
        raise ValueError(f"{what} must be [lat, lon] or {{\"lat\", \"lon\"}}, not {value!r}")
    lat, lon = float(value[0]), float(value[1])
    if not (-90.0 <= lat <= 90.0 and -180.0 <= lon <= 180.0):
        raise ValueError(f"{what} {lat}, {lon} is not a position")
    return [lat, lon]


def area_object(obj: dict[str, Any]) -> dict[str, Any]:
    """The world model object of an area message (ValueError when the shape is wrong)."""
    goal = str(GOAL.extract(obj))
    if "polygon" in obj:
        vertices = obj["polygon"]
        if not isinstance(vertices, list) or not 3 <= len(vertices) <= MAX_VERTICES:
            raise ValueError(f"polygon must list 3 to {MAX_VERTICES} [lat, lon] vertices")
        polygon = [_point(v, "polygon vertex") for v in vertices]
        center = [sum(p[0] for p in polygon) / len(polygon),
                  sum(p[1] for p in polygon) / len(polygon)]
        attributes: dict[str, Any] = {"polygon": polygon}
    elif "center" in obj:
        center = _point(obj["center"], "center")
        radius = obj.get("radius")
        if (isinstance(radius, bool) or not isinstance(radius, (int, float))
                or not 0 < radius <= MAX_RADIUS_M):
            raise ValueError(f"radius must be a number of metres in (0, {MAX_RADIUS_M:g}]")
        attributes = {"radius_m": float(radius)}
    else:
        raise ValueError("an area needs \"polygon\", or \"center\" and \"radius\"")
    attributes["priority"] = PRIORITY.extract(obj)
    return {"id": goal, "kind": "area", "position": {"lat": center[0], "lon": center[1]},
            "attributes": attributes}


class WildfireEvents(ExternalAdapter):
    """The operator's user interface, seen through MQTT."""

    #: What this adapter reads from [events] (checked by `mrss check`).
    OPTIONS = (Option("topic_prefix", str, "mrss/ui", "prefix of the operator's topics"),)

    def start(self) -> None:
        prefix = str(self.options.get("topic_prefix", "mrss/ui")).rstrip("/")
        self.world: WorldModelClient = self.world_model()
        self.on_json(f"{prefix}/area", self.on_area)
        self.map_json(f"{prefix}/cancel", CANCEL)
        self.map_json(f"{prefix}/priority", PRIORITY_CHANGE)
        self.on_json(f"{prefix}/teleop", self.on_teleop)
        self.on_json(f"{prefix}/hold", self.on_hold)

    def on_area(self, topic: str, obj: dict[str, Any]) -> None:
        """Store the area's shape (the RCL grounds it from there), then the goal percept.

        The world model is looked up for this call; while it is down the upsert raises
        WorldModelUnavailable and the events manager retries the whole message.
        """
        area = area_object(obj)
        args = AREA.args(obj, topic=topic)  # a bad payload is refused before it is stored
        self.world.upsert(area)
        self.percept(AREA.functor, *args)

    def on_hold(self, topic: str, obj: dict[str, Any]) -> None:
        """All robots hold (the percept hold_all), or go on (it is removed)."""
        try:
            on = HOLD_ON.extract(obj)
        except ValueError as exc:
            raise PayloadError(str(exc), topic=topic) from None
        self.percept("hold_all", op="add" if on else "remove")

    def on_teleop(self, topic: str, obj: dict[str, Any]) -> None:
        """Teleop on/off: the new state is perceived, the old one is not any more."""
        robot, on = TELEOP.args(obj, topic=topic, robots=self.robots)  # no unknown robot
        state, old = ("on", "off") if on else ("off", "on")
        self.percept("teleop", robot, Atom(old), op="remove")
        self.percept("teleop", robot, Atom(state))

