"""The operator's commands of tuimission, as the wildfire project reads them (without
its world model: an area is only its goal percept)."""

from __future__ import annotations

from typing import Any

from mrss.api import Atom, ExternalAdapter, Field, JsonMapping, PayloadError

GOAL = Field("goal", "atom")
AREA = JsonMapping("area_goal_received", GOAL, Field("priority", "int", default=1))
CANCEL = JsonMapping("goal_cancelled", GOAL)
PRIORITY = JsonMapping("prioritychange", GOAL, Field("priority", "int"))
TELEOP = JsonMapping("teleop", Field("robot", "atom"), Field("on", "bool"))
HOLD_ON = Field("on", "bool")  # ops/hold: hold_all added (true) or removed (false)


class MissionEvents(ExternalAdapter):
    """ops/area, ops/cancel, ops/priority, ops/teleop, ops/hold -> percepts."""

    def start(self) -> None:
        self.map_json("ops/area", AREA)
        self.map_json("ops/cancel", CANCEL)
        self.map_json("ops/priority", PRIORITY)
        self.on_json("ops/teleop", self.on_teleop)
        self.on_json("ops/hold", self.on_hold)

    def on_teleop(self, topic: str, obj: dict[str, Any]) -> None:
        robot, on = TELEOP.args(obj, topic=topic)
        state, old = ("on", "off") if on else ("off", "on")
        self.percept("teleop", robot, Atom(old), op="remove")
        self.percept("teleop", robot, Atom(state))

    def on_hold(self, topic: str, obj: dict[str, Any]) -> None:
        try:
            on = HOLD_ON.extract(obj)
        except ValueError as exc:
            raise PayloadError(str(exc), topic=topic) from None
        self.percept("hold_all", op="add" if on else "remove")
