"""Skills of the AMADEE-24 rover: start -> run -> (interrupt) -> finish.

DriveTo, ReturnHome and Observe use the rover's MQTT link (an MqttLink); all hold the
robot's "motion" resource (the rover stands still while it observes) and wait on the
link's telemetry with `self.wait`, so an interrupt ends them at once; a drive stops the
robot in `finish` when interrupted.
"""

from __future__ import annotations

import time
from collections.abc import Callable

from mrss.api import LinkError, Resource, Skill, SkillOutcome, distance_m

MOTION = Resource("motion", per_robot=True)   # one moving action per robot at a time
ARRIVED_M = 3.0
POLL_S = 0.05


class MoveSkill(Skill):
    """Shared: wait on telemetry, interruptibly, and know when the robot is there."""

    resources = (MOTION,)

    def until(self, condition: Callable[[], bool], timeout: float, what: str) -> bool:
        """Wait until `condition()`; False if interrupted or after `timeout` (`reason`)."""
        deadline = time.monotonic() + timeout
        while not condition():
            self.link.require_up()           # LinkDown fails the action with its cause
            if time.monotonic() > deadline:
                self.reason = f"{what}: not done after {timeout:.0f} s"
                return False
            if self.wait(POLL_S):            # True when interrupted
                return False
        return True

    def near(self, lat: float, lon: float) -> bool:
        position = self.link.latest("position")
        return position is not None and \
            distance_m(position["lat"], position["lon"], lat, lon) <= ARRIVED_M


class DriveTo(MoveSkill):
    """Drive to a point."""

    def __init__(self, lat: float, lon: float) -> None:
        self.lat, self.lon = lat, lon

    def run(self) -> bool:
        if self.near(self.lat, self.lon):
            return True
        self.link.goto(self.lat, self.lon, wait=False)
        return self.until(lambda: self.near(self.lat, self.lon) and self.stopped(), 900.0,
                          "drive")

    def stopped(self) -> bool:
        """The rover stands still (the arm may deploy): the rules check that too."""
        return float((self.link.latest("position") or {}).get("speed", 1.0)) == 0.0

    def finish(self, outcome: SkillOutcome) -> None:
        if outcome is SkillOutcome.INTERRUPTED:
            try:
                self.link.stop()
            except LinkError as exc:
                self.reason = f"could not stop the robot: {exc}"


class ReturnHome(DriveTo):
    """Drive back to the habitat (the rover's base) and stop there."""

    def __init__(self) -> None:
        pass

    def run(self) -> bool:
        self.link.return_to_base(wait=False)
        return self.until(lambda: bool((self.link.latest("status") or {}).get("at_base"))
                          and self.stopped(), 900.0, "return home")


class Observe(MoveSkill):
    """A science task where the rover stands: image, spectrum, radar profile or sample.

    Waits until the rover is stopped (the arm of `spectrum` and `sample` only deploys
    then; the rover refuses an `observe` command while it moves, too), sends the
    `observe` command, holds the rover still for `dwell_s` and records the reading the
    rover answered (what, where, which sample slot) as the action's progress.
    """

    def __init__(self, what: str, dwell_s: float) -> None:
        self.what, self.dwell_s = what, dwell_s

    def run(self) -> bool:
        if not self.until(lambda: float((self.link.latest("position") or {})
                                        .get("speed", 1.0)) == 0.0, 30.0, "rover stopped"):
            return False
        answer = self.link.command("observe", instrument=self.what, wait=True, timeout=10.0)
        self.record_progress(taken=self.what, reading=answer.reason)
        return not self.wait(self.dwell_s)
