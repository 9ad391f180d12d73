"""Skills of the wildfire robots (paper IV-E): start -> run -> (interrupt) -> finish.

UAV (a `MavlinkLink`): CoverArea, ReturnHome (optionally waiting for the battery
swap), Land. UGV (an `MqttLink`): GotoPoint, Pump, SupplyWater (drive, then pump),
ReturnToBase (optionally waiting for the tank to refill), TeleopSwitch.

Conventions:
- every skill that moves a robot holds the robot's "motion" resource, so two actions
  never steer one robot at once (a higher-priority action pre-empts a lower one);
- `run` waits by polling telemetry with `self.wait`, so an interrupt ends it quickly;
  the robot is stopped in `finish` (on the skill's own thread, before the resource is
  released), never behind the back of the action that takes over;
- progress (`waypoint`, `pumped`) is recorded as it is made: a suspended or restarted
  action continues where it left off;
- CoverArea publishes its lawnmower plan (`publish_plan`), SupplyWater the line to its
  hotspot: the dashboard's map draws the lanes done and left; SupplyWater also says the
  hotspot's state (`supply` records: supplying, supplied, new again if it ends undone),
  which datalayer.py writes to the world model and the map colours (project.toml [map]).
"""

from __future__ import annotations

import logging
import time
from collections.abc import Callable
from typing import Any

from mrss.api import LinkError, Resource, Skill, SkillOutcome, TransientError, distance_m

log = logging.getLogger("mrss.rcl.skills")
MOTION = Resource("motion", per_robot=True)
POLL_S = 0.05
ARRIVED_M = 3.0
STALE_S = 5.0  # no new tank record while pumping for this long: TransientError
TELEOP_WAIT_S = 3600.0  # a UGV skill waits this long for the operator to hand the robot back


class RobotSkill(Skill):
    """Shared helpers: wait for a condition on telemetry, interruptibly."""

    def until(self, condition: Callable[[], bool], timeout: float, what: str) -> bool:
        """Wait until `condition()`; False if interrupted (or timed out: `reason` says so)."""
        deadline = time.monotonic() + timeout
        while not condition():
            if self.interrupted:
                return False
            self.link.require_up()
            if time.monotonic() > deadline:
                self.reason = f"{what}: not done after {timeout:.0f}s"
                return False
            self.wait(POLL_S)
        return not self.interrupted

    def latest(self, kind: str, key: str, default: Any = None) -> Any:
        record = self.link.latest(kind)
        return default if record is None else record.get(key, default)

    def near(self, lat: float, lon: float, tolerance: float = ARRIVED_M) -> bool:
        position = self.link.latest("position")
        return position is not None and \
            distance_m(position["lat"], position["lon"], lat, lon) <= tolerance


# -------------------------------------------------------------------------------- UAV
class UavSkill(RobotSkill):
    """A UAV skill: stops the vehicle in place (LOITER) when interrupted."""

    resources = (MOTION,)

    def finish(self, outcome: SkillOutcome) -> None:
        if outcome is SkillOutcome.INTERRUPTED:
            try:
                self.link.set_mode("LOITER")
            except LinkError as exc:  # nothing to hold if it cannot hear us
                self.reason = f"could not hold position: {exc}"

    def airborne(self, altitude: float) -> bool:
        """Take off to `altitude` if on the ground; be in GUIDED mode either way."""
        self.link.wait_up(10.0)
        if self.link.landed or not self.link.armed:
            log.info("%s: taking off to %.0f m", self.robot, altitude)
            self.link.set_mode("GUIDED")
            self.link.arm()
            self.link.takeoff(altitude)
            return self.until(lambda: self.latest("position", "relative_alt", 0.0)
                              >= altitude - 1.0, 120.0, "takeoff")
        if self.link.mode != "GUIDED":
            self.link.set_mode("GUIDED")
        return True

    def fly_to(self, lat: float, lon: float, altitude: float) -> bool:
        self.link.goto(lat, lon, altitude)
        return self.until(lambda: self.near(lat, lon), 300.0, f"flight to {lat:.6f},{lon:.6f}")


class CoverArea(UavSkill):
    """Fly lawnmower waypoints; progress `waypoint` = how many were reached, `first` =
    the waypoint this run started from."""

    progress_bound = 120.0  # s from the start (take-off) or a waypoint to the next one

    def __init__(self, waypoints: list[list[float]], altitude: float,
                 start_at: Callable[[], int] = lambda: 0,
                 settled: Callable[[], bool] = lambda: True, settle_s: float = 0.0) -> None:
        self.waypoints = waypoints
        self.altitude = altitude
        self.start_at, self.settled, self.settle_s = start_at, settled, settle_s

    def run(self) -> bool:
        # the area's earlier cover may still be stopping: where it stopped is known once
        # it has ended (at most settle_s, then from what is known)
        deadline = time.monotonic() + self.settle_s
        while not self.settled() and time.monotonic() < deadline:
            if self.interrupted:
                return False
            self.wait(POLL_S)
        if not self.settled():
            log.warning("%s: %s: the area's earlier cover has not ended after %.0f s; "
                        "starting from what is known", self.robot, self.action.goal,
                        self.settle_s)
        done = max(self.start_at(), int(self.progress.get("waypoint", 0) or 0))
        # where this run starts: 0, or the waypoint an earlier run of the area reached (on
        # this UAV before a suspension, or on one lost mid-cover whose task it took over)
        self.record_progress(first=done, waypoints=len(self.waypoints))
        self.publish_plan(self.waypoints, done)  # the dashboard's map: lanes done and left
        if not self.airborne(self.altitude):
            return False
        for index in range(done, len(self.waypoints)):
            lat, lon = self.waypoints[index]
            if not self.fly_to(lat, lon, self.altitude):
                return False
            self.record_progress(waypoint=index + 1, waypoints=len(self.waypoints))
            self.publish_plan(self.waypoints, index + 1)
            log.info("%s: %s waypoint %d/%d", self.robot, self.action.goal, index + 1,
                     len(self.waypoints))
        return True


class ReturnHome(UavSkill):
    """Fly home and land (RTL); with `charge_to`, wait until the battery is that full."""

    def __init__(self, charge_to: float | None = None) -> None:
        self.charge_to = charge_to

    def run(self) -> bool:
        self.link.wait_up(10.0)
        if not (self.link.landed and not self.link.armed):
            log.info("%s: returning home", self.robot)
            self.link.return_to_launch()
            if not self.until(lambda: bool(self.link.landed) and not self.link.armed, 600.0,
                              "return home"):
                return False
        if self.charge_to is None:
            return True
        log.info("%s: landed; battery swap to %.0f%%", self.robot, self.charge_to)
        return self.until(lambda: self.latest("battery", "remaining", 0.0) >= self.charge_to,
                          600.0, "battery recharge")


class Land(UavSkill):
    """Land where the vehicle is."""

    def run(self) -> bool:
        self.link.wait_up(10.0)
        self.link.land()
        return self.until(lambda: bool(self.link.landed) and not self.link.armed, 300.0,
                          "landing")


# -------------------------------------------------------------------------------- UGV
class UgvSkill(RobotSkill):
    """A UGV skill: the robot stops (pump too) when the skill is interrupted.

    Like the UAV's, it waits for the link before its first command (`ready`): an
    action restored by a restarted RCL starts while the new link still connects to the
    broker, and would otherwise fail at once ("connecting to ..."). And it waits while
    the robot is in the operator's hands (its `status` says teleop): the RCL gives a
    robot that says so no task addressed to a role, but an action addressed to it by
    name, or one it held when teleop began, starts when the operator hands it back,
    instead of failing on the robot's refusal ("teleop is on")."""

    resources = (MOTION,)

    def ready(self) -> bool:
        """The link up and the robot not in teleop; False if interrupted meanwhile."""
        self.link.wait_up(10.0)
        if self.latest("status", "teleop", False):
            log.info("%s: in teleop: %s waits until it is handed back", self.robot,
                     self.action.goal)
        return self.until(lambda: not self.latest("status", "teleop", False), TELEOP_WAIT_S,
                          "the end of teleop")

    def finish(self, outcome: SkillOutcome) -> None:
        if outcome is SkillOutcome.INTERRUPTED:
            try:
                self.link.stop()
            except LinkError as exc:
                self.reason = f"could not stop the robot: {exc}"

    def drive_to(self, lat: float, lon: float) -> bool:
        if not self.ready():
            return False
        if self.near(lat, lon):
            return True
        log.info("%s: driving to %.6f,%.6f", self.robot, lat, lon)
        self.link.goto(lat, lon, wait=False)
        return self.until(lambda: self.near(lat, lon), 900.0, f"drive to {lat:.6f},{lon:.6f}")

    def pump(self, litres: float, stale_s: float = STALE_S) -> bool:
        """Pump until `litres` in total were delivered (progress `pumped` counts them).

        The pump is judged stopped only on tank telemetry received after the pump
        command: a record from before it says "not pumping" and would fail a pump that
        just started. A robot that sends no new tank record for `stale_s` (frozen,
        out of range while its link still counts as up) fails the skill with
        TransientError (cause `transient`: the agent tries again) rather than as a
        pump that stopped (chaos: a UGV frozen right after pumping began failed
        "pump stopped after 0 of 60 l", and its hotspot never got water)."""
        pumped = float(self.progress.get("pumped", 0.0) or 0.0)
        wanted = litres - pumped
        if wanted <= 0.5:
            return True
        if not self.ready():
            return False
        # the link is up on a robot's first telemetry, a moment before its tank record
        if not self.until(lambda: self.link.latest("tank") is not None, stale_s,
                          "tank telemetry"):
            if self.interrupted:
                return False
            raise TransientError(f"{self.robot}: no tank telemetry for {stale_s:.0f} s")
        start = float(self.latest("tank", "level", 0.0))
        log.info("%s: pumping %.0f l (%.0f l in the tank)", self.robot, wanted, start)
        sent = time.time()  # the clock of telemetry `ts` (stamped by the link on arrival)
        self.link.pump(True, litres=wanted)

        def delivered() -> float:
            return max(0.0, start - float(self.latest("tank", "level", start)))

        saved = idle_since = heard = time.monotonic()
        last_ts = sent
        while delivered() < wanted - 0.5 and not self.interrupted:
            now = time.monotonic()
            tank = self.link.latest("tank")
            ts = float(tank.get("ts", 0.0)) if tank is not None else 0.0
            if ts > last_ts:  # a record newer than the command (and than the last one)
                last_ts, heard = ts, now
                if tank is not None and tank.get("pumping", False):
                    idle_since = now
            elif now - heard > stale_s:
                self.record_progress(pumped=round(pumped + delivered(), 1))
                raise TransientError(f"{self.robot}: no tank telemetry for {stale_s:.0f} s "
                                     f"while pumping ({pumped + delivered():.0f} of "
                                     f"{litres:.0f} l)")
            if heard > idle_since and now - idle_since > 1.5:
                # fresh records say idle: telemetry lags the pump by up to a period
                self.reason = f"pump stopped after {pumped + delivered():.0f} of {litres:.0f} l"
                break
            self.link.require_up()
            if now - saved > 0.5:
                self.record_progress(pumped=round(pumped + delivered(), 1))
                saved = now
            self.wait(POLL_S)
        self.record_progress(pumped=round(pumped + delivered(), 1))
        return not self.interrupted and delivered() >= wanted - 0.5


class GotoPoint(UgvSkill):
    def __init__(self, lat: float, lon: float) -> None:
        self.lat, self.lon = lat, lon

    def run(self) -> bool:
        return self.drive_to(self.lat, self.lon)


class Pump(UgvSkill):
    progress_bound = 30.0  # pumping records progress every 0.5 s; stale telemetry: 5 s
    def __init__(self, litres: float, stale_s: float = STALE_S) -> None:
        self.litres, self.stale_s = litres, stale_s

    def run(self) -> bool:
        return self.pump(self.litres, self.stale_s)


class SupplyWater(UgvSkill):
    """Drive to a hotspot and pump `litres` on it; resumed, it drives back and pumps the rest."""

    def __init__(self, lat: float, lon: float, litres: float) -> None:
        self.lat, self.lon, self.litres = lat, lon, litres

    def run(self) -> bool:
        self.tell_state("supplying")
        self.publish_plan([[self.lat, self.lon]], 0)  # the map: a line to the hotspot
        if not self.drive_to(self.lat, self.lon):
            return False
        if not self.pump(self.litres):
            return False
        self.tell_state("supplied")
        return True

    def finish(self, outcome: SkillOutcome) -> None:
        super().finish(outcome)
        if outcome is not SkillOutcome.SUCCEEDED:
            self.tell_state("new")  # not supplied (yet): the next try says "supplying"

    def tell_state(self, state: str) -> None:
        """The hotspot's state in the world model (datalayer.py: `supply` records)."""
        self.publish_data(type="supply", target=self.action.goal, state=state)


class ReturnToBase(UgvSkill):
    """Drive back to base; with `refill`, wait until the tank is (nearly) full."""

    def __init__(self, refill: bool = False) -> None:
        self.refill = refill

    def run(self) -> bool:
        if not self.ready():
            return False
        log.info("%s: returning to base%s", self.robot, " to refill" if self.refill else "")
        self.link.return_to_base(wait=False)
        if not self.until(lambda: bool(self.latest("status", "at_base", False))
                          and self.latest("position", "speed", 1.0) == 0.0, 900.0,
                          "return to base"):
            return False
        if not self.refill:
            return True
        return self.until(lambda: self.latest("tank", "level", 0.0)
                          >= 0.98 * self.latest("tank", "capacity", 1.0), 600.0, "refill")


class TeleopSwitch(RobotSkill):
    """Hand the robot to direct remote control (on) or take it back (off)."""

    def __init__(self, on: bool) -> None:
        self.on = on

    def run(self) -> bool:
        self.link.wait_up(10.0)
        self.link.teleop(self.on)
        log.info("%s: teleoperation %s", self.robot, "on" if self.on else "off")
        return True
