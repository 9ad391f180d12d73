"""The tuidemo RCL: `patrol(Robot, Area, Legs)` drives a simulated UGV `Legs` legs."""

from __future__ import annotations

from collections.abc import Mapping
from typing import Any

from mrss.api import Action, RobotCommLayer, Skill


class SimUgv:
    """A stand-in for a robot link: each leg of a patrol takes `leg` seconds."""

    def __init__(self, name: str, leg: float) -> None:
        self.name = name
        self.leg = leg


class Patrol(Skill):
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


class DemoRcl(RobotCommLayer):
    """One recipe: patrol(robot, area, legs)."""

    def connect_robot(self, robot: str, options: Mapping[str, Any]) -> Any:
        return SimUgv(robot, float(options.get("leg", 0.4)))

    def refine_action(self, action: Action) -> list[Skill]:
        if action.name == "patrol":
            return [Patrol(int(action.args[2]))]  # type: ignore[call-overload]
        return super().refine_action(action)
