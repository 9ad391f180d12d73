"""The fleetloss RCL: `sweep(Robot, Goal, Strips)` covers `Strips` strips, `STRIP_S`
seconds each, keeping the strip it is at as progress (`step`): a sweep handed to another
robot goes on from there. It records where it began (`first`) and who swept (`by`). A
strip counts only when the robot was heard during it (a position report, 4 a second
from the simulator), as a robot out of reach reports nothing it did: a robot lost
mid-sweep leaves the rest to the robot that takes the task over."""

from __future__ import annotations

import time

from mrss.api import Action, RobotCommLayer, Skill

STRIP_S = 0.4


class Sweep(Skill):
    """`strips` strips from the progress's `step` on (interrupted: failed)."""

    def __init__(self, strips: int) -> None:
        self.strips = strips

    def start(self) -> None:
        first = self.progress.get("step", 0)
        self.record_progress(first=first, step=first, by=self.robot)

    def run(self) -> bool:
        step = int(self.progress.get("step", 0))
        while step < self.strips:
            began = time.time()
            if self.wait(STRIP_S):
                return False
            if not self.heard_since(began):
                continue
            step += 1
            self.record_progress(step=step)
        return True

    def heard_since(self, began: float) -> bool:
        """Whether the link received a position report at or after `began` (wall time)."""
        record = self.link.latest("position") if self.link is not None else None
        return record is not None and float(record.get("ts", 0.0)) >= began


class Rcl(RobotCommLayer):
    def refine_action(self, action: Action) -> list[Skill]:
        if action.name == "sweep":
            return [Sweep(int(action.args[2]))]
        return super().refine_action(action)
