"""The end-to-end test project's Robot Communication Layer.

The robots are `SimRobot`s, a small simulation of the physical robot (travel time per
waypoint, arrivals, stop commands); everything else is the real RCL.
"""

from __future__ import annotations

import threading
from collections.abc import Mapping
from typing import Any

from skills import Gate, Jam, Note, Survey, Travel

from mrss.api import Action, RobotCommLayer, Skill


class SimRobot:
    """A simulated robot: `leg` seconds per waypoint; counts arrivals and stops."""

    def __init__(self, name: str, leg: float) -> None:
        self.name = name
        self.leg = leg
        self.lock = threading.Lock()
        self.arrivals: list[int] = []
        self.stops = 0
        self.notes = 0

    def arrive(self, waypoint: int) -> None:
        with self.lock:
            self.arrivals.append(waypoint)

    def stop(self) -> None:
        with self.lock:
            self.stops += 1


class E2eRcl(RobotCommLayer):
    """Recipes: cover/patrol(R, G, N) travel N waypoints, survey(R, G, N) also needs the
    airspace, probe(R, G) raises, report(R, G) is instant."""

    interrupt_timeout = 2.0

    def connect_robot(self, robot: str, options: Mapping[str, Any]) -> SimRobot:
        return SimRobot(robot, float(options.get("leg", 0.05)))

    def refine_action(self, action: Action) -> list[Skill]:
        if action.name in ("cover", "patrol"):
            return [Travel(int(action.args[2]))]  # type: ignore[arg-type]
        if action.name == "survey":
            return [Survey(int(action.args[2]))]  # type: ignore[arg-type]
        if action.name == "probe":
            return [Jam()]
        if action.name == "report":
            return [Note()]
        if action.name == "gated" and self.run_dir is not None:
            return [Gate(self.run_dir / f"{action.goal}.gate")]
        return super().refine_action(action)
