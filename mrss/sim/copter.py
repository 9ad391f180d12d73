"""The flight model of the simulated UAV: ArduCopter's modes, arming rules and kinematics.

Pure state and arithmetic, no sockets: `mrss.sim.uav` feeds it MAVLink commands and
sends what it reports. Distances in metres, altitudes relative to home, time in
simulated seconds.
"""

from __future__ import annotations

from dataclasses import dataclass, field

from mrss.links.ardupilot import COPTER_MODES, mode_name
from mrss.links.geo import approach, bearing_deg, distance_m, step_towards
from mrss.links.mavconn import MAV

ARMABLE_MODES = {COPTER_MODES[m] for m in ("STABILIZE", "ACRO", "ALT_HOLD", "GUIDED", "LOITER")}
GUIDED, AUTO, RTL, LAND, BRAKE = (COPTER_MODES[m]
                                   for m in ("GUIDED", "AUTO", "RTL", "LAND", "BRAKE"))
# FS_GCS_ENABLE -> the mode the GCS failsafe switches to (SmartRTL and DO_LAND_START are
# not simulated: they fall back to RTL or LAND as ArduCopter does without them).
FS_GCS_MODES = {1: RTL, 3: RTL, 4: LAND, 5: LAND, 6: RTL, 7: BRAKE}
FORCE_DISARM_MAGIC = 21196
ARRIVED_M = 1.0
ARRIVED_ALT_M = 0.3
RELATIVE_FRAMES = {MAV.MAV_FRAME_GLOBAL_RELATIVE_ALT, MAV.MAV_FRAME_GLOBAL_RELATIVE_ALT_INT,
                   MAV.MAV_FRAME_GLOBAL_TERRAIN_ALT, MAV.MAV_FRAME_GLOBAL_TERRAIN_ALT_INT}


class Refused(Exception):
    """The vehicle refuses a command; `text` is what ArduCopter would say in a STATUSTEXT."""

    def __init__(self, text: str, result: int = MAV.MAV_RESULT_FAILED) -> None:
        super().__init__(text)
        self.text = text
        self.result = result


@dataclass
class CopterParams:
    """Performance figures, settable over MAVLink as ArduCopter parameters."""

    speed_mps: float = 10.0          # WPNAV_SPEED
    climb_mps: float = 2.5           # WPNAV_SPEED_UP
    descent_mps: float = 1.5         # WPNAV_SPEED_DN
    land_mps: float = 0.5            # LAND_SPEED
    rtl_alt_m: float = 15.0          # RTL_ALT
    endurance_s: float = 1200.0      # hover time on a full battery
    failsafe_pct: float = 10.0       # BATT_LOW: below it the vehicle returns home


@dataclass
class NavItem:
    """A stored mission item (MISSION_ITEM_INT fields, coordinates in degrees)."""

    seq: int
    command: int
    frame: int = MAV.MAV_FRAME_GLOBAL_RELATIVE_ALT
    params: tuple[float, float, float, float] = (0.0, 0.0, 0.0, 0.0)
    lat: float = 0.0
    lon: float = 0.0
    alt: float = 0.0


@dataclass
class CopterModel:
    """A quadcopter's state; `step(dt)` moves it on by `dt` simulated seconds."""

    home_lat: float
    home_lon: float
    home_alt: float = 0.0
    params: CopterParams = field(default_factory=CopterParams)
    mode: int = COPTER_MODES["STABILIZE"]
    armed: bool = False
    landed: bool = True
    battery_pct: float = 100.0
    lat: float = 0.0
    lon: float = 0.0
    alt: float = 0.0
    heading: float = 0.0
    velocity: tuple[float, float, float] = (0.0, 0.0, 0.0)  # north, east, down m/s
    target: tuple[float, float, float] | None = None
    mission: list[NavItem] = field(default_factory=list)
    mission_seq: int = 0
    texts: list[tuple[int, str]] = field(default_factory=list)
    reached: list[int] = field(default_factory=list)
    _hold_until: float | None = None
    _clock: float = 0.0
    _failsafe_done: bool = False

    def __post_init__(self) -> None:
        self.lat, self.lon = self.home_lat, self.home_lon

    # -- commands ------------------------------------------------------------------------
    def arm(self) -> None:
        """Arm the motors, as ArduCopter's pre-arm checks allow."""
        if self.armed:
            return
        if self.mode not in ARMABLE_MODES:
            raise Refused("Arm: Mode not armable")
        if self.battery_pct <= self.params.failsafe_pct:
            raise Refused("Arm: Battery below minimum")
        self.armed = True
        self.texts.append((MAV.MAV_SEVERITY_INFO, "Arming motors"))

    def disarm(self, force: bool = False) -> None:
        """Disarm; refused in flight unless forced (then the vehicle drops)."""
        if not self.armed:
            return
        if not self.landed and not force:
            raise Refused("Disarm: vehicle is flying")
        if not self.landed:
            self._touch_down("Crash: disarmed in flight")
        self.armed = False
        self.target = None
        self.texts.append((MAV.MAV_SEVERITY_INFO, "Disarming motors"))

    def set_mode(self, number: int) -> None:
        """Change flight mode; refused for unknown modes and AUTO without a takeoff."""
        if number not in COPTER_MODES.values():
            raise Refused(f"Unknown mode {number}", MAV.MAV_RESULT_FAILED)
        if number == AUTO:
            self._enter_auto()
        if number == GUIDED and self.mode != GUIDED:
            self.target = (self.lat, self.lon, self.alt) if not self.landed else None
        self.mode = number
        self._hold_until = None
        self.texts.append((MAV.MAV_SEVERITY_INFO, f"Mode {mode_name(number)}"))

    def _enter_auto(self) -> None:
        if self.mission_seq < 1 or self.mission_seq >= len(self.mission):
            self.mission_seq = 1
        if self.armed and self.landed:
            first = self.mission[1] if len(self.mission) > 1 else None
            if first is None or first.command != MAV.MAV_CMD_NAV_TAKEOFF:
                raise Refused("Auto: Missing Takeoff Cmd")

    def takeoff(self, alt: float) -> None:
        """Climb to `alt` metres above home; only armed, landed and in GUIDED."""
        if self.mode != GUIDED:
            raise Refused("Takeoff: not in GUIDED mode")
        if not self.armed:
            raise Refused("Takeoff: not armed")
        if not self.landed:
            raise Refused("Takeoff: already flying")
        if alt <= 0:
            raise Refused("Takeoff: altitude must be positive", MAV.MAV_RESULT_DENIED)
        self.landed = False
        self.target = (self.lat, self.lon, alt)

    def goto(self, lat: float, lon: float, alt: float) -> None:
        """Fly to a position (relative altitude) in GUIDED mode while airborne."""
        if self.mode != GUIDED:
            raise Refused("Guided: not in GUIDED mode")
        if self.landed or not self.armed:
            raise Refused("Guided: vehicle is not flying")
        self.target = (lat, lon, max(alt, 1.0))

    def relative_alt(self, frame: int, alt: float) -> float:
        """An altitude given in MAVLink `frame`, as metres above home."""
        return alt if frame in RELATIVE_FRAMES else alt - self.home_alt

    def gcs_failsafe(self, enable: int) -> None:
        """ArduCopter's GCS failsafe event for FS_GCS_ENABLE `enable` (never 0).

        Disarmed: only a warning. Armed on the ground: disarm. Landing after a battery
        failsafe: keep landing. Otherwise switch to the mode of `enable`.
        """
        warn = MAV.MAV_SEVERITY_WARNING
        if not self.armed:
            self.texts.append((warn, "GCS Failsafe"))
            return
        if self.landed:
            self.texts.append((warn, "GCS Failsafe - Disarming"))
            self.armed, self.target = False, None
            self.texts.append((MAV.MAV_SEVERITY_INFO, "Disarming motors"))
            return
        if self.mode == LAND and self._failsafe_done:
            self.texts.append((warn, "GCS + Battery Failsafe - Continuing Landing"))
            return
        self.texts.append((warn, "GCS Failsafe"))
        mode = FS_GCS_MODES.get(enable, LAND)
        if self.mode != mode:
            self.set_mode(mode)

    # -- time ----------------------------------------------------------------------------
    def step(self, dt: float) -> None:
        """Advance the simulation by `dt` seconds."""
        self._clock += dt
        before = (self.lat, self.lon, self.alt)
        if self.armed and self.landed:
            self._idle_on_ground()
        if self.armed and not self.landed:
            if self.mode == GUIDED and self.target is not None:
                self._move_to(*self.target, dt)
            elif self.mode == AUTO:
                self._run_mission(dt)
            elif self.mode == RTL:
                self._return_home(dt)
            elif self.mode == LAND:
                self._descend(dt)
        self._drain_battery(dt)
        if dt > 0:
            north = distance_m(before[0], self.lon, self.lat, self.lon)
            east = distance_m(self.lat, before[1], self.lat, self.lon)
            north = north if self.lat >= before[0] else -north
            east = east if self.lon >= before[1] else -east
            self.velocity = (north / dt, east / dt, (before[2] - self.alt) / dt)

    def _idle_on_ground(self) -> None:
        if self.mode in (LAND, RTL):
            self.armed = False  # ArduCopter disarms once landed in these modes
            self.texts.append((MAV.MAV_SEVERITY_INFO, "Disarming motors"))
        elif self.mode == AUTO and self._current_command() == MAV.MAV_CMD_NAV_TAKEOFF:
            self.landed = False

    def _current_command(self) -> int | None:
        if 0 < self.mission_seq < len(self.mission):
            return self.mission[self.mission_seq].command
        return None

    def _move_to(self, lat: float, lon: float, alt: float, dt: float) -> bool:
        if distance_m(self.lat, self.lon, lat, lon) > ARRIVED_M / 10:
            self.heading = bearing_deg(self.lat, self.lon, lat, lon)
        self.lat, self.lon = step_towards(self.lat, self.lon, lat, lon, self.params.speed_mps * dt)
        rate = self.params.climb_mps if alt > self.alt else self.params.descent_mps
        self.alt = approach(self.alt, alt, rate * dt)
        return (distance_m(self.lat, self.lon, lat, lon) <= ARRIVED_M
                and abs(self.alt - alt) <= ARRIVED_ALT_M)

    def _descend(self, dt: float) -> bool:
        rate = self.params.land_mps if self.alt < 10.0 else self.params.descent_mps
        self.alt = max(0.0, self.alt - rate * dt)
        if self.alt <= 0.0:
            self._touch_down("Land complete")
            self.armed = False
            self.texts.append((MAV.MAV_SEVERITY_INFO, "Disarming motors"))
            return True
        return False

    def _touch_down(self, text: str) -> None:
        self.alt = 0.0
        self.landed = True
        self.target = None
        self.texts.append((MAV.MAV_SEVERITY_INFO, text))

    def _return_home(self, dt: float) -> bool:
        safe_alt = max(self.params.rtl_alt_m, 0.0)
        far = distance_m(self.lat, self.lon, self.home_lat, self.home_lon) > ARRIVED_M
        if far and self.alt < safe_alt - ARRIVED_ALT_M:
            self.alt = approach(self.alt, safe_alt, self.params.climb_mps * dt)
            return False
        if far:
            self._move_to(self.home_lat, self.home_lon, max(self.alt, safe_alt), dt)
            return False
        return self._descend(dt)

    def _run_mission(self, dt: float) -> None:
        if self.mission_seq >= len(self.mission):
            return  # mission complete: hold position, as ArduCopter does in AUTO
        item = self.mission[self.mission_seq]
        done = self._run_item(item, dt)
        if done:
            self.reached.append(item.seq)
            self.mission_seq += 1
            self._hold_until = None
            if self.mission_seq >= len(self.mission):
                self.texts.append((MAV.MAV_SEVERITY_INFO, "Mission complete"))

    def _run_item(self, item: NavItem, dt: float) -> bool:
        alt = self.relative_alt(item.frame, item.alt)
        if item.command == MAV.MAV_CMD_NAV_TAKEOFF:
            self.alt = approach(self.alt, alt, self.params.climb_mps * dt)
            return abs(self.alt - alt) <= ARRIVED_ALT_M
        if item.command in (MAV.MAV_CMD_NAV_WAYPOINT, MAV.MAV_CMD_NAV_LOITER_TIME):
            if not self._move_to(item.lat, item.lon, alt, dt):
                return False
            hold = item.params[0]
            if self._hold_until is None:
                self._hold_until = self._clock + hold
            return self._clock >= self._hold_until
        if item.command == MAV.MAV_CMD_NAV_RETURN_TO_LAUNCH:
            return self._return_home(dt)
        if item.command == MAV.MAV_CMD_NAV_LAND:
            has_spot = item.lat != 0.0 or item.lon != 0.0
            if has_spot and not self._move_to(item.lat, item.lon, self.alt, dt):
                return False
            return self._descend(dt)
        if item.command == MAV.MAV_CMD_DO_CHANGE_SPEED and item.params[1] > 0:
            self.params.speed_mps = item.params[1]
        return True  # other DO_ commands take effect at once or are not simulated

    def _drain_battery(self, dt: float) -> None:
        if not self.armed:
            return
        rate = 100.0 / self.params.endurance_s
        if self.landed:
            rate /= 20  # idling on the ground
        self.battery_pct = max(0.0, self.battery_pct - rate * dt)
        low = self.battery_pct <= self.params.failsafe_pct
        if low and not self.landed and not self._failsafe_done and self.mode not in (RTL, LAND):
            self._failsafe_done = True
            self.texts.append((MAV.MAV_SEVERITY_CRITICAL, "Battery failsafe: RTL"))
            self.mode = RTL
        if self.battery_pct <= 0.0 and not self.landed and self.mode != LAND:
            self.texts.append((MAV.MAV_SEVERITY_CRITICAL, "Battery empty: LAND"))
            self.mode = LAND
