"""Symbol and Data Layer of the AMADEE-24 rover: telemetry -> world model, legality.

- `position`, `status` and `battery` records of the rover's link update its world model
  object (position; `speed`, `heading`, `at_base`, `battery` attributes);
- `legal(Action)` (the reasoner's `query(legal, [Action], Verdict)`) checks an action
  against the operational rules of legality.py, with the rover's state and the zones,
  crew and parameters of the world model. The answer is `["legal"]` or
  `["illegal", Rule, Detail]` (an action that cannot be checked is refused by the rule
  `unchecked`); every verdict is also stored in the world model as the
  object `verdict_<goal>` (kind `verdict`: action, legal, rule, detail, geometry), where
  the operator's console reads it.
"""

from __future__ import annotations

from collections.abc import Mapping
from pathlib import Path
from typing import Any

from mrss.api import DataLayer, external, import_project_module

legality = import_project_module(Path(__file__).resolve().parent, "legality.py")


class AmadeeData(DataLayer):
    """The rover's telemetry in the world model; the legality of its actions."""

    @external("legal")
    def legal(self, action: str) -> list[str]:
        """The verdict on `action` (its AgentSpeak text), stored and answered."""
        found = legality.judge(str(action), self.world)
        goal = legality.goal_of(str(action))
        if goal is not None:
            self.world.upsert({"id": f"verdict_{goal}", "kind": "verdict",
                               "attributes": {"action": str(action), "legal": found.legal,
                                              "rule": found.rule, "detail": found.detail,
                                              "geometry": found.geometry}})
        if found.legal:
            self.log.info("legal: %s", action)
        else:
            self.log.warning("illegal: %s by %s: %s", action, found.rule, found.detail)
        answer: list[str] = found.as_answer()
        return answer

    def on_telemetry(self, robot: str, data: Mapping[str, Any]) -> None:
        kind = data.get("type")
        if kind == "position":
            self._update(robot, data, ("heading", "speed"))
        elif kind == "status":
            self._update(robot, data, ("mode", "at_base", "teleop"))
        elif kind == "battery" and isinstance(data.get("remaining"), (int, float)):
            self._update(robot, {"battery": data["remaining"]}, ("battery",))

    def _update(self, robot: str, data: Mapping[str, Any], keys: tuple[str, ...]) -> None:
        obj: dict[str, Any] = {"id": robot, "kind": "robot",
                               "attributes": {k: data[k] for k in keys if k in data}}
        if "lat" in data and "lon" in data:
            obj["position"] = {"lat": data["lat"], "lon": data["lon"]}
        self.world.upsert(obj)
