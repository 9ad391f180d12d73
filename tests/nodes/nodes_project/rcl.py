"""A test project's Robot Communication Layer, loaded by RclService from this folder.

The robot link is a fake of the physical robot: `TimedRobot` takes `leg` seconds per
waypoint (its simulated travel time) and stops when halted.
"""

from __future__ import annotations

import threading
from collections.abc import Mapping
from typing import Any

from mrss.api import Action, RobotCommLayer, Skill


class TimedRobot:
    """A simulated robot that needs `leg` seconds to reach each waypoint."""

    def __init__(self, name: str, leg: float) -> None:
        self.name = name
        self.leg = leg
        self._halt = threading.Event()
        self.closed = False

    def goto(self, waypoint: object) -> bool:
        return not self._halt.wait(self.leg)

    def halt(self) -> None:
        self._halt.set()

    def resume_motion(self) -> None:
        self._halt.clear()

    def close(self) -> None:
        self.closed = True


class Patrol(Skill):
    """Visit waypoints from the last one reached."""

    progress_bound = 30.0  # a waypoint every `leg` s (0.05 s in the tests)

    def __init__(self, waypoints: list[Any]) -> None:
        self.waypoints = waypoints

    def start(self) -> None:
        self.link.resume_motion()

    def run(self) -> bool:
        index = int(self.progress.get("waypoint", 0))  # type: ignore[arg-type]
        while index < len(self.waypoints):
            if self.interrupted or not self.link.goto(self.waypoints[index]):
                return False
            index += 1
            self.record_progress(waypoint=index)
        return True

    def terminate(self) -> None:
        self.link.halt()


class Explode(Skill):
    def run(self) -> None:
        raise ValueError("gearbox jammed")


class ProjectRcl(RobotCommLayer):
    """Recipes: patrol(robot, goal, waypoints), explode(robot, goal)."""

    def connect_robot(self, robot: str, options: Mapping[str, Any]) -> Any:
        return TimedRobot(robot, float(options.get("leg", 0.05)))

    def refine_action(self, action: Action) -> list[Skill]:
        if action.name == "patrol":
            return [Patrol(list(action.args[2]))]  # type: ignore[arg-type]
        if action.name == "explode":
            return [Explode()]
        return super().refine_action(action)
