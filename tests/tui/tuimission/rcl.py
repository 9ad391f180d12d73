"""The tuimission RCL: the wildfire agent's actions on stand-in robots. `cover` drives
100 legs of `leg` seconds each (long enough to be cancelled); the others end at once."""

from __future__ import annotations

from collections.abc import Mapping
from typing import Any

from mrss.api import Action, RobotCommLayer, Skill


class StandIn:
    """A robot link stand-in: each leg takes `leg` seconds."""

    def __init__(self, name: str, leg: float) -> None:
        self.name = name
        self.leg = leg


class Legs(Skill):
    """Drive `legs` legs, one progress step each; resumes from the last leg done."""

    def __init__(self, legs: int) -> None:
        self.legs = legs

    def run(self) -> bool:
        done = int(self.progress.get("leg", 0))  # type: ignore[arg-type]
        while done < self.legs:
            if self.wait(self.link.leg):
                return False  # interrupted (cancel, suspend, teleop)
            done += 1
            self.record_progress(leg=done, of=self.legs)
        return True


class MissionRcl(RobotCommLayer):
    """cover(R, G): 100 legs; supply_water: 10; recharge, refill, teleop_mode: at once."""

    def connect_robot(self, robot: str, options: Mapping[str, Any]) -> Any:
        return StandIn(robot, float(options.get("leg", 0.3)))

    def refine_action(self, action: Action) -> list[Skill]:
        if action.name == "cover":
            return [Legs(100)]
        if action.name == "supply_water":
            return [Legs(10)]
        if action.name in ("recharge", "refill", "teleop_mode"):
            return [Legs(0)]
        return super().refine_action(action)
