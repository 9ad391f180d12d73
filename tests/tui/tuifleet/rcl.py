"""The tuifleet RCL: robots standing where their tables say (position and battery for
their bids); `patrol(Robot, Area, Legs)` drives `Legs` legs of 0.5 s, resuming from the
last leg done."""

from __future__ import annotations

from collections.abc import Mapping
from typing import Any

from mrss.api import Action, Check, Option, RobotCommLayer, Skill


class StandingRobot:
    """A stand-in for a robot link: where it is and its battery, for its bids."""

    def __init__(self, lat: float, lon: float, battery: float) -> None:
        self.lat, self.lon, self.battery = lat, lon, battery


class Patrol(Skill):
    """Drive `legs` legs, one progress step each; resumes from the last leg done."""

    def __init__(self, legs: int) -> None:
        self.legs = legs

    def run(self) -> bool:
        done = int(self.progress.get("leg", 0))
        while done < self.legs:
            if self.wait(0.5):
                return False  # interrupted
            done += 1
            self.record_progress(leg=done, of=self.legs)
        return True


class FleetRcl(RobotCommLayer):
    """One recipe: patrol(robot, area, legs)."""

    robot_settings = (Option("at", list, None, "where the robot stands", Check.POSITION),
                      Option("battery", float, 100.0, "% of battery"))

    def connect_robot(self, robot: str, options: Mapping[str, Any]) -> Any:
        lat, lon = options["at"]
        return StandingRobot(float(lat), float(lon), float(options.get("battery", 100.0)))

    def refine_action(self, action: Action) -> list[Skill]:
        if action.name == "patrol":
            return [Patrol(int(action.args[2]))]
        return super().refine_action(action)
