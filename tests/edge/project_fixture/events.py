"""Events adapter of the edge test project: UI messages over MQTT become percepts."""

from __future__ import annotations

from typing import Any

from mrss.actors.events.adapter import ExternalAdapter
from mrss.agentspeak.literals import Atom
from mrss.edge.payloads import Field


class FixtureAdapter(ExternalAdapter):
    """Area goals by schema; cancellations and priority changes by hand."""

    def start(self) -> None:
        prefix = self.options.get("topic_prefix", "fixture")
        self.map_json(f"{prefix}/area", "area_goal_received",
                      Field("area", "symbol"), Field("priority", "int"))
        self.on_json(f"{prefix}/cancel", self.cancel)
        self.on_json(f"{prefix}/priority", self.priority)
        self.on_message(f"{prefix}/crash", self.crash)

    def cancel(self, topic: str, obj: dict[str, Any]) -> None:
        self.percept("goal_cancelled", Atom(obj["goal"]))

    def priority(self, topic: str, obj: dict[str, Any]) -> None:
        # Two percepts from one message: both or neither reach the bus.
        self.percept("priority_change_seen")
        level = obj["level"]
        if not isinstance(level, int):
            raise ValueError("level must be an integer")
        self.percept("prioritychange", Atom(obj["goal"]), level)

    def crash(self, topic: str, payload: bytes) -> None:
        raise RuntimeError("adapter bug")
