"""Skills of the two simulated robots: start -> run -> (interrupt) -> finish.

FlyTo drives a MAVLink copter (`self.link` is a MavlinkLink), DriveTo an MQTT ground
robot (an MqttLink); both hold the robot's "motion" resource and wait on the link's
telemetry with `self.wait`, so an interrupt ends them at once, and stop the robot in
`finish` when interrupted. Each shows where it goes on the dashboard's map
(`publish_plan`: a skill that follows waypoints sends them all, again as each is
reached; the RCL clears the plan when the action ends). ADAPT: your robots'
capabilities (docs/robots.md lists what each link can do).
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


class FlyTo(MoveSkill):
    """Take off if on the ground, fly to a point and hover there."""

    def __init__(self, lat: float, lon: float, altitude: float) -> None:
        self.lat, self.lon, self.altitude = lat, lon, altitude

    def run(self) -> bool:
        self.link.wait_up(10.0)              # the link first (see DriveTo)
        if self.link.landed or not self.link.armed:
            self.link.set_mode("GUIDED")
            self.link.arm()
            self.link.takeoff(self.altitude)
            if not self.until(lambda: (self.link.latest("position") or {})
                              .get("relative_alt", 0.0) >= self.altitude - 1.0,
                              120.0, "takeoff"):
                return False
        elif self.link.mode != "GUIDED":
            self.link.set_mode("GUIDED")
        self.publish_plan([[self.lat, self.lon]], 0)  # the dashboard's map: where it goes
        self.link.goto(self.lat, self.lon, self.altitude)
        return self.until(lambda: self.near(self.lat, self.lon), 300.0, "flight")

    def finish(self, outcome: SkillOutcome) -> None:
        if outcome is SkillOutcome.INTERRUPTED:
            try:
                self.link.set_mode("LOITER")  # hover where it is
            except LinkError as exc:
                self.reason = f"could not hold position: {exc}"


class DriveTo(MoveSkill):
    """Drive to a point."""

    def __init__(self, lat: float, lon: float) -> None:
        self.lat, self.lon = lat, lon

    def run(self) -> bool:
        # Wait for the link before the first command (as FlyTo does): an action that a
        # restarted RCL resumes starts while the new link still connects to the broker,
        # and its command would fail at once ("connecting to ...").
        self.link.wait_up(10.0)
        if self.near(self.lat, self.lon):
            return True
        self.publish_plan([[self.lat, self.lon]], 0)
        self.link.goto(self.lat, self.lon, wait=False)
        return self.until(lambda: self.near(self.lat, self.lon), 900.0, "drive")

    def finish(self, outcome: SkillOutcome) -> None:
        if outcome is SkillOutcome.INTERRUPTED:
            try:
                self.link.stop()
            except LinkError as exc:
                self.reason = f"could not stop the robot: {exc}"
