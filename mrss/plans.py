"""A robot's planned path as robot data: the record a skill's `publish_plan` sends and
the dashboard's map draws (segments flown dim, those left bright); docs/tui.md, "Map,
alerts, help".

    {"type": "plan", "action": "<uuid>", "goal": "<goal>",
     "waypoints": [[lat, lon], ...], "next": <how many were reached>}

An empty `waypoints` list clears the robot's plan (the RCL sends one when the action
that published a plan ends).
"""

from __future__ import annotations

from collections.abc import Sequence

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
                                    "waypoints": points, "next": done}  # type: ignore[dict-item]
    if goal:
        record["goal"] = goal
    return record


def clear_record(action: str) -> dict[str, JsonValue]:
    """The record that takes the plan of `action` off the map."""
    return {"type": PLAN_RECORD, "action": action, "waypoints": [], "next": 0}
