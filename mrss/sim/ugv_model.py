"""The simulated ground robot: driving, battery, and a water tank with a pump.

Pure state and arithmetic: `mrss.sim.ugv` feeds it commands from MQTT and publishes
what it reports. A command with an id gets an "accepted" or "rejected" answer, and a
command that takes time (goto, return_to_base, pump with litres) a terminal one later:
"done", "failed" or "cancelled" (when another command supersedes it).

Failsafe (`lose_controller`, called by `mrss.sim.ugv` when the controller's heartbeats
stop): HOLD stops driving (a pump job goes on), STOP stops driving and pumping, RTL
stops pumping and drives back to base — except in teleop, where the robot only stops.
The running jobs end "cancelled" with a ``failsafe: ...`` reason, and `failsafe` stays
true until the next accepted command.
"""

from __future__ import annotations

import math
import time
from dataclasses import dataclass, field

from mrss.links.failsafe import FailsafeAction
from mrss.links.geo import bearing_deg, distance_m, offset
from mrss.links.ugv_protocol import UgvAck, UgvCommand, UgvTelemetry

ARRIVED_M = 1.0


@dataclass
class UgvParams:
    """Performance figures of the simulated ground robot."""

    max_speed_mps: float = 3.0
    base_radius_m: float = 5.0
    tank_capacity_l: float = 200.0
    pump_rate_lps: float = 5.0
    refill_rate_lps: float = 10.0
    endurance_s: float = 3600.0      # driving time on a full battery
    charge_pct_per_s: float = 0.5
    sample_slots: int = 4            # sample containers a rover's `observe sample` fills


@dataclass
class _Job:
    """A command still running, with what remains to do."""

    id: str | None
    kind: str
    litres_left: float | None = None


@dataclass
class UgvModel:
    """A ground robot's state; `step(dt)` moves it on by `dt` simulated seconds."""

    robot_id: str
    base_lat: float
    base_lon: float
    params: UgvParams = field(default_factory=UgvParams)
    battery: float = 100.0
    lat: float = 0.0
    lon: float = 0.0
    heading: float = 0.0
    speed: float = 0.0
    tank: float = -1.0
    pumping: bool = False
    teleop: bool = False
    mode: str = "idle"
    target: tuple[float, float] | None = None
    drive: tuple[float, float] = (0.0, 0.0)  # teleop speed m/s, heading deg
    failsafe: bool = False
    samples: int = 0                 # sample slots filled
    observations: int = 0
    _move: _Job | None = None
    _pump: _Job | None = None
    _answers: list[UgvAck] = field(default_factory=list)

    def __post_init__(self) -> None:
        self.lat, self.lon = self.base_lat, self.base_lon
        if self.tank < 0:
            self.tank = self.params.tank_capacity_l

    @property
    def at_base(self) -> bool:
        return distance_m(self.lat, self.lon, self.base_lat, self.base_lon) \
            <= self.params.base_radius_m

    def take_answers(self) -> list[UgvAck]:
        """Answers produced since the last call, oldest first."""
        answers, self._answers = self._answers, []
        return answers

    def _answer(self, ident: str | None, status: str, reason: str = "") -> None:
        if ident is not None:
            self._answers.append(UgvAck(ident, status, reason))

    def _end(self, job: _Job | None, status: str, reason: str) -> None:
        if job is not None:
            self._answer(job.id, status, reason)

    # -- commands --------------------------------------------------------------------------
    def apply(self, command: UgvCommand) -> None:
        """Carry out a validated command; its answers go to `take_answers()`."""
        handler = getattr(self, f"_cmd_{command.cmd}")
        refusal: str | None = handler(command)
        if refusal is not None:
            self._answer(command.id, "rejected", refusal)
        else:
            self.failsafe = False  # commanded again: the controller has taken over

    def lose_controller(self, action: FailsafeAction, why: str) -> None:
        """Act on the failsafe `action`: the controller is gone (`why` says how)."""
        self.failsafe = True
        reason = f"failsafe: {why}"
        if action is not FailsafeAction.HOLD:
            self._end(self._pump, "cancelled", reason)
            self._pump, self.pumping = None, False
        going_home = action is FailsafeAction.RTL and not self.teleop and self.battery > 0
        if going_home and self._move is not None and self._move.kind == "return":
            return  # already on its way
        self._end(self._move, "cancelled", reason)
        self._move, self.target, self.speed, self.drive = None, None, 0.0, (0.0, 0.0)
        self.mode = "teleop" if self.teleop else "idle"
        if going_home:
            self._move = _Job(None, "return")
            self.target, self.mode = (self.base_lat, self.base_lon), "return"

    def _cmd_goto(self, c: UgvCommand) -> str | None:
        assert c.lat is not None and c.lon is not None
        return self._start_move(c.id, "goto", (c.lat, c.lon))

    def _cmd_return_to_base(self, c: UgvCommand) -> str | None:
        return self._start_move(c.id, "return", (self.base_lat, self.base_lon))

    def _start_move(self, ident: str | None, mode: str, target: tuple[float, float]) -> str | None:
        if self.teleop:
            return "teleop is on"
        if self.battery <= 0:
            return "battery empty"
        self._end(self._move, "cancelled", f"superseded by {mode}")
        self._move = _Job(ident, mode)
        self.target, self.mode = target, mode
        self._answer(ident, "accepted")
        return None

    def _cmd_stop(self, c: UgvCommand) -> str | None:
        self._end(self._move, "cancelled", "stopped")
        self._end(self._pump, "cancelled", "stopped")
        self._move = self._pump = None
        self.target, self.pumping, self.speed = None, False, 0.0
        self.drive = (0.0, 0.0)
        self.mode = "teleop" if self.teleop else "idle"
        self._answer(c.id, "done")
        return None

    def _cmd_pump(self, c: UgvCommand) -> str | None:
        if not c.on:
            self._end(self._pump, "cancelled", "pump stopped")
            self._pump, self.pumping = None, False
            self._answer(c.id, "done")
            return None
        if self.tank <= 0:
            return "tank empty"
        self._end(self._pump, "cancelled", "superseded by pump")
        self._pump, self.pumping = _Job(c.id, "pump", c.litres), True
        self._answer(c.id, "accepted")
        return None

    def _cmd_teleop(self, c: UgvCommand) -> str | None:
        if c.on:
            self._end(self._move, "cancelled", "teleop on")
            self._move, self.target = None, None
        self.teleop = bool(c.on)
        self.drive, self.speed = (0.0, 0.0), 0.0
        self.mode = "teleop" if self.teleop else "idle"
        self._answer(c.id, "done")
        return None

    def _cmd_drive(self, c: UgvCommand) -> str | None:
        if not self.teleop:
            return "teleop is off"
        assert c.speed is not None and c.heading is not None
        self.drive = (min(c.speed, self.params.max_speed_mps), c.heading)
        self._answer(c.id, "done")
        return None

    def _cmd_observe(self, c: UgvCommand) -> str | None:
        """An instrument reading (or a sample) where the robot stands; refused while it
        moves. The answer's reason is the reading: what, where, which slot."""
        if self.speed > 0.0 or self._move is not None:
            return "moving: instruments deploy only when the robot is stopped"
        if c.instrument == "sample":
            if self.samples >= self.params.sample_slots:
                return f"no free sample slot ({self.samples} of {self.params.sample_slots} used)"
            self.samples += 1
        self.observations += 1
        slot = f" in slot {self.samples}" if c.instrument == "sample" else ""
        self._answer(c.id, "done", f"{c.instrument} #{self.observations} at "
                                   f"{self.lat:.6f},{self.lon:.6f}{slot}")
        return None

    # -- time ------------------------------------------------------------------------------
    def step(self, dt: float) -> None:
        """Advance the simulation by `dt` seconds."""
        self._drive(dt)
        self._run_pump(dt)
        if self.at_base and self.speed == 0.0:
            if not self.pumping:
                self.tank = min(self.params.tank_capacity_l,
                                self.tank + self.params.refill_rate_lps * dt)
            self.battery = min(100.0, self.battery + self.params.charge_pct_per_s * dt)

    def _drive(self, dt: float) -> None:
        p = self.params
        self.speed = 0.0
        if self.battery <= 0.0:
            self._end(self._move, "failed", "battery empty")
            self._move, self.target, self.drive = None, None, (0.0, 0.0)
            return
        if self.teleop and self.drive[0] > 0:
            self.heading = self.drive[1]
            step = self.drive[0] * dt
            rad = math.radians(self.heading)
            self.lat, self.lon = offset(self.lat, self.lon, step * math.cos(rad),
                                        step * math.sin(rad))
            self.speed = self.drive[0]
        elif self.target is not None:
            remaining = distance_m(self.lat, self.lon, *self.target)
            if remaining > ARRIVED_M / 10:
                self.heading = bearing_deg(self.lat, self.lon, *self.target)
            step = min(remaining, p.max_speed_mps * dt)
            if remaining > 0:
                f = step / remaining
                self.lat += (self.target[0] - self.lat) * f
                self.lon += (self.target[1] - self.lon) * f
                self.speed = step / dt if dt > 0 else 0.0
            if distance_m(self.lat, self.lon, *self.target) <= ARRIVED_M:
                self.lat, self.lon = self.target
                self._end(self._move, "done", "arrived")
                self._move, self.target, self.mode = None, None, "idle"
        if self.speed > 0:
            self.battery = max(0.0, self.battery - 100.0 / p.endurance_s * dt)

    def _run_pump(self, dt: float) -> None:
        if not self.pumping:
            return
        amount = min(self.tank, self.params.pump_rate_lps * dt)
        job = self._pump
        if job is not None and job.litres_left is not None:
            amount = min(amount, job.litres_left)
            job.litres_left -= amount
        self.tank -= amount
        if job is not None and job.litres_left is not None and job.litres_left <= 1e-9:
            self._end(job, "done", "delivered")
            self._pump, self.pumping = None, False
        elif self.tank <= 1e-9:
            self.tank = 0.0
            if job is not None and job.litres_left is not None:
                self._end(job, "failed", "tank empty")
            else:
                self._end(job, "done", "tank empty")
            self._pump, self.pumping = None, False

    def telemetry(self, controller: bool = True) -> UgvTelemetry:
        """The current state as a telemetry sample (`controller`: heartbeats heard now)."""
        return UgvTelemetry(
            id=self.robot_id, ts=time.time(), lat=self.lat, lon=self.lon,
            heading=round(self.heading, 2) % 360.0, speed=round(self.speed, 3),
            battery=round(self.battery, 3),
            tank=round(min(self.tank, self.params.tank_capacity_l), 3),
            tank_capacity=self.params.tank_capacity_l, pumping=self.pumping, mode=self.mode,
            at_base=self.at_base, teleop=self.teleop, failsafe=self.failsafe,
            controller=controller)
