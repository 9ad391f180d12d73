"""A robot's planned path as robot data: the record a skill's `publish_plan` sends and
the dashboard's map draws (segments flown dim, those left bright); docs/tui.md, "Map,
alerts, help".

    {"type": "plan", "action": "<uuid>", "goal": "<goal>",
     "waypoints": [[lat, lon], ...], "next": <how many were reached>}

An empty `waypoints` list clears the robot's plan (the RCL sends one when the action
that published a plan ends). The RCL keeps each open action's latest plan (`PlanBoard`)
and sends it again with its snapshot, so a dashboard that attaches late sees it at once.
"""

from __future__ import annotations

import threading
from collections.abc import Mapping, Sequence

from mrss.messages import JsonValue

#: The `type` of the robot data record a skill's `publish_plan` sends (docs/tui.md).
PLAN_RECORD = "plan"
#: Waypoints in one plan record (the data layer's list limit); a longer plan is thinned.
PLAN_MAX_WAYPOINTS = 256


def plan_record(action: str, waypoints: Sequence[Sequence[float]], next_index: int,
                goal: str = "") -> dict[str, JsonValue]:
    """The robot data record of a planned path: `waypoints` as [lat, lon], the first
    `next_index` of them reached. A plan longer than PLAN_MAX_WAYPOINTS is thinned
    (evenly, the last one kept) and `next` scaled to match."""
    points = [[float(p[0]), float(p[1])] for p in waypoints]
    done = max(0, min(int(next_index), len(points)))
    if len(points) > PLAN_MAX_WAYPOINTS:
        stride = -(-len(points) // (PLAN_MAX_WAYPOINTS - 1))
        kept = list(range(0, len(points), stride))
        if kept[-1] != len(points) - 1:
            kept.append(len(points) - 1)
        done = sum(1 for i in kept if i < done)
        points = [points[i] for i in kept]
    record: dict[str, JsonValue] = {"type": PLAN_RECORD, "action": action,
                                    "waypoints": points, "next": done}
    if goal:
        record["goal"] = goal
    return record


def clear_record(action: str) -> dict[str, JsonValue]:
    """The record that takes the plan of `action` off the map."""
    return {"type": PLAN_RECORD, "action": action, "waypoints": [], "next": 0}


class PlanBoard:
    """The latest plan record of each open action (by uuid), with its robot; thread-safe
    (skills send plans from their threads, the RCL's snapshot reads them)."""

    def __init__(self) -> None:
        self._lock = threading.Lock()
        self._plans: dict[str, tuple[str, dict[str, JsonValue]]] = {}

    def sent(self, robot: str, uuid: str, record: Mapping[str, JsonValue]) -> None:
        """A skill of action `uuid` sent `record` (a plan; an empty one is kept too)."""
        with self._lock:
            self._plans[uuid] = (robot, dict(record))

    def ended(self, uuid: str) -> bool:
        """Action `uuid` ended: forget its plan; True if it had sent one (to clear)."""
        with self._lock:
            return self._plans.pop(uuid, None) is not None

    def current(self) -> list[tuple[str, dict[str, JsonValue]]]:
        """(robot, record) of every open action's latest plan."""
        with self._lock:
            return list(self._plans.values())
