"""The fleetloss RCL: `sweep(Robot, Goal, Strips)` covers `Strips` strips, `STRIP_S`
seconds each, keeping the strip it is at as progress (`step`): a sweep handed to another
robot goes on from there. It records where it began (`first`) and who swept (`by`). A
strip counts only while the robot's link is up, as a robot out of reach reports nothing
it did: a robot lost mid-sweep leaves the rest to the robot that takes the task over."""

from __future__ import annotations

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
        step = int(self.progress.get("step", 0))  # type: ignore[arg-type]
        while step < self.strips:
            if self.wait(STRIP_S):
                return False
            if self.link is not None and not self.link.up:
                continue
            step += 1
            self.record_progress(step=step)
        return True


class Rcl(RobotCommLayer):
    def refine_action(self, action: Action) -> list[Skill]:
        if action.name == "sweep":
            return [Sweep(int(action.args[2]))]  # type: ignore[arg-type]
        return super().refine_action(action)
