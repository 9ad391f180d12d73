"""A test project's RCL for re-allocation, loaded by RclService from here.

Its robots are simulated UAVs (`mrss sim uav` processes) reached over their real MAVLink
links (the default `connect_robot`). `sweep(Robot, Goal, Steps)` covers `Steps` strips,
`STRIP_S` seconds each, keeping the strip it is at as progress (`step`): a sweep given
to another robot goes on from there; it records where it began (`first`) and who swept
(`by`). With a fourth argument, a file name, its `start()` waits for that file first
(a test's gate between the award and the skill's start).
"""

from __future__ import annotations

from pathlib import Path

from mrss.api import Action, RobotCommLayer, Skill

STRIP_S = 0.25


class Sweep(Skill):
    """`steps` strips from the progress's `step` on (interrupted: failed)."""

    def __init__(self, steps: int, gate: str = "") -> None:
        self.steps, self.gate = steps, gate

    def start(self) -> None:
        while self.gate and not Path(self.gate).exists():
            if self.wait(0.05):  # the fake robot polls its gate, interruptibly
                return
        first = self.progress.get("step", 0)
        self.record_progress(first=first, step=first, by=self.robot)

    def run(self) -> bool:
        step = int(self.progress.get("step", 0))  # type: ignore[arg-type]
        while step < self.steps:
            if self.wait(STRIP_S):
                return False
            step += 1
            self.record_progress(step=step)
        return True


class Rcl(RobotCommLayer):
    def refine_action(self, action: Action) -> list[Skill]:
        if action.name == "sweep":
            gate = str(action.args[3]) if len(action.args) > 3 else ""
            return [Sweep(int(action.args[2]), gate)]  # type: ignore[arg-type]
        return super().refine_action(action)
