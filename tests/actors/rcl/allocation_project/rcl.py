"""A test project's RCL for tasks addressed to a role, loaded by RclService from here.

Each robot is a fake of the physical robot standing where its table says (`at`), with
the battery its table says; `survey(Robot, Goal, Seconds)` keeps it busy that long
(or until interrupted).
"""

from __future__ import annotations

from collections.abc import Mapping
from typing import Any

from mrss.api import Action, Check, Option, Resource, RobotCommLayer, Skill


class StandingRobot:
    """A robot that stays where it is: position and battery for its bids."""

    def __init__(self, lat: float, lon: float, battery: float) -> None:
        self.lat, self.lon, self.battery = lat, lon, battery


class Survey(Skill):
    """Busy for `seconds` (interrupted: failed); one survey at a time per robot."""

    resources = (Resource("motion", per_robot=True),)

    def __init__(self, seconds: float) -> None:
        self.seconds = seconds

    def run(self) -> bool:
        return not self.wait(self.seconds)


class Rcl(RobotCommLayer):
    robot_settings = (Option("at", list, None, "where the robot stands", Check.POSITION),
                      Option("battery", float, 100.0, "% of battery"))

    def connect_robot(self, robot: str, options: Mapping[str, Any]) -> Any:
        lat, lon = options["at"]
        return StandingRobot(float(lat), float(lon), float(options.get("battery", 100.0)))

    def refine_action(self, action: Action) -> list[Skill]:
        if action.name == "survey":
            return [Survey(float(action.args[2]))]  # type: ignore[arg-type]
        return super().refine_action(action)
