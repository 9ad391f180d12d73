"""The simulated UAV: a MAVLink vehicle that answers a ground station as ArduCopter does.

Run it as a process (``mrss sim uav --out udpout:127.0.0.1:14550``, or
``python -m mrss.sim.uav``) or as a thread in tests (`SimUav.start()` / `stop()`).
Heartbeats and telemetry go out at fixed wall-clock rates; flight, battery and mission
timers run `speedup` times faster than the wall clock.
"""

from __future__ import annotations

import argparse
import logging
import signal
import sys
import threading
import time
from collections.abc import Sequence
from dataclasses import dataclass
from types import FrameType
from typing import Any

from mrss.links.ardupilot import HotspotReport, format_hotspot, mode_name
from mrss.links.failsafe import FailsafePolicy, parse_policy
from mrss.links.mavconn import MAV, MavConnection
from mrss.links.mavlink_signing import load_key
from mrss.sim.copter import AUTO, GUIDED, CopterModel
from mrss.sim.gcs_failsafe import GcsFailsafe
from mrss.sim.hotspots import Hotspot, ThermalCamera, parse_hotspots
from mrss.sim.mission_server import MissionServer
from mrss.sim.uav_handlers import UavHandlers
from mrss.sim.uav_params import UavParams

log = logging.getLogger("mrss.sim.uav")

CLI_FAILSAFE_KEYS = ("--failsafe", "--failsafe-timeout")
DEFAULT_HOME = (-35.363262, 149.165237, 584.0)  # ArduPilot SITL's default home
DEFAULT_RATES = {  # message id -> seconds between sends
    MAV.MAVLINK_MSG_ID_HEARTBEAT: 1.0,
    MAV.MAVLINK_MSG_ID_GLOBAL_POSITION_INT: 0.25,
    MAV.MAVLINK_MSG_ID_SYS_STATUS: 0.5,
    MAV.MAVLINK_MSG_ID_VFR_HUD: 0.5,
    MAV.MAVLINK_MSG_ID_EXTENDED_SYS_STATE: 1.0,
    MAV.MAVLINK_MSG_ID_MISSION_CURRENT: 1.0,
    MAV.MAVLINK_MSG_ID_POSITION_TARGET_GLOBAL_INT: 0.5,
}

# Sensors reported present, enabled and healthy; the geofence bit is only "healthy"
# (not breached), as ArduCopter reports it when no fence is enabled.
SENSORS = (MAV.MAV_SYS_STATUS_SENSOR_3D_GYRO | MAV.MAV_SYS_STATUS_SENSOR_3D_ACCEL
           | MAV.MAV_SYS_STATUS_SENSOR_3D_MAG | MAV.MAV_SYS_STATUS_SENSOR_ABSOLUTE_PRESSURE
           | MAV.MAV_SYS_STATUS_SENSOR_GPS | MAV.MAV_SYS_STATUS_SENSOR_MOTOR_OUTPUTS
           | MAV.MAV_SYS_STATUS_AHRS | MAV.MAV_SYS_STATUS_SENSOR_BATTERY)


@dataclass(frozen=True)
class UavSnapshot:
    """The vehicle's state at one instant, for tests and logs."""

    mode: str
    armed: bool
    landed: bool
    lat: float
    lon: float
    alt: float
    battery_pct: float
    mission_items: int
    mission_seq: int
    hotspots_seen: frozenset[int]
    failsafe: bool = False  # the GCS failsafe is in force


class SimUav:
    """One simulated copter speaking MAVLink 2 on a pymavlink connection string."""

    def __init__(self, url: str, *, sysid: int = 1,
                 home: tuple[float, float, float] = DEFAULT_HOME,
                 hotspots: Sequence[Hotspot] = (), speedup: float = 1.0,
                 camera_radius_m: float = 25.0, failsafe: FailsafePolicy | None = None,
                 signing_key: bytes | None = None) -> None:
        if speedup <= 0:
            raise ValueError("speedup must be positive")
        self.url = url
        self.sysid = sysid
        self.signing_key = signing_key
        self.speedup = speedup
        self.model = CopterModel(home[0], home[1], home[2])
        self.camera = ThermalCamera(hotspots, radius_m=camera_radius_m)
        self.failsafe = GcsFailsafe(self.model, failsafe)
        self._lock = threading.Lock()
        self._stop = threading.Event()
        self._thread: threading.Thread | None = None
        self._conn: MavConnection | None = None
        self._started = time.monotonic()
        self._sim_time = 0.0
        self._due: dict[int, float] = {}
        self._mission: MissionServer | None = None
        self._handlers: UavHandlers | None = None
        self._last = 0.0
        self.rates: dict[int, float] = dict(DEFAULT_RATES)  # message id -> seconds between sends

    # -- life cycle ------------------------------------------------------------------------
    def start(self) -> None:
        """Run the vehicle on a background thread."""
        self._thread = threading.Thread(target=self.run, name=f"sim-uav-{self.sysid}",
                                        daemon=True)
        self._thread.start()

    def stop(self) -> None:
        """Stop the vehicle and close its socket."""
        self._stop.set()
        if self._thread is not None:
            self._thread.join(timeout=5)

    def refused(self) -> dict[str, int]:
        """Incoming messages refused under signing, by reason ({} without signing)."""
        conn = self._conn
        return conn.refused() if conn is not None else {}

    def snapshot(self) -> UavSnapshot:
        """A consistent copy of the vehicle's state."""
        with self._lock:
            m = self.model
            return UavSnapshot(mode_name(m.mode), m.armed, m.landed, m.lat, m.lon, m.alt,
                               m.battery_pct, len(m.mission), m.mission_seq,
                               frozenset(self.camera.seen), self.failsafe.active)

    def run(self) -> None:
        """Serve until `stop()`: answer messages, fly, send telemetry."""
        self.open()
        conn = self._conn
        assert conn is not None
        try:
            while not self._stop.is_set():
                conn.wait_readable(0.02)
                self.service(time.monotonic(), drain=False)
        finally:
            self.close()

    def open(self) -> None:
        """Open the vehicle's socket; then `service` it (what `run` does on its thread, or
        a fleet's event loop for many vehicles, `mrss.sim.fleet`)."""
        conn = MavConnection(self.url, source_system=self.sysid,
                             source_component=MAV.MAV_COMP_ID_AUTOPILOT1,
                             signing_key=self.signing_key, name=f"sim uav {self.sysid}",
                             log=log)
        self._conn = conn
        self._mission = MissionServer(conn.conn.mav, conn.send, self.model)
        params = UavParams(self.model, self.camera, self.sysid, self.failsafe)
        self._handlers = UavHandlers(conn.conn.mav, conn.send, self.model, self._mission,
                                     params, self.sysid, self._send_message, self.failsafe)
        self._last = time.monotonic()
        log.info("sim uav %d on %s (speedup %.1f, %d hotspots, signing %s)", self.sysid,
                 self.url, self.speedup, len(self.camera.hotspots),
                 "on" if self.signing_key else "off")

    def fileno(self) -> int:
        """The socket to wait on (an open vehicle's)."""
        assert self._conn is not None
        return int(self._conn.conn.port.fileno())

    def service(self, now: float, *, drain: bool = True) -> None:
        """Handle what arrived (one message, or all with `drain`), then `tick`."""
        self.receive(drain=drain)
        self.tick(now)

    def receive(self, *, drain: bool = True) -> None:
        """Handle the next message that arrived, or all of them with `drain`."""
        conn, handlers = self._conn, self._handlers
        assert conn is not None and handlers is not None
        with self._lock:
            try:
                while (msg := conn.recv(timeout=0.0)) is not None:
                    handlers.handle(msg)
                    if not drain:
                        break
            except Exception:  # no input may stop the vehicle
                log.exception("error handling a MAVLink message; continuing")

    def tick(self, now: float) -> None:
        """Fly on to `now` and send the telemetry that is due."""
        handlers, mission = self._handlers, self._mission
        assert handlers is not None and mission is not None
        with self._lock:
            self.failsafe.check(now)
            self._advance((now - self._last) * self.speedup)
            self._last = now
            mission.tick(now)
            self._send_due(now, handlers.intervals)

    def close(self) -> None:
        """Close the vehicle's socket."""
        if self._conn is not None:
            self._conn.close()

    # -- simulation ------------------------------------------------------------------------
    def _advance(self, dt: float) -> None:
        m = self.model
        m.step(dt)
        self._sim_time += dt
        for spot in self.camera.scan(m.lat, m.lon, m.alt):
            text = format_hotspot(HotspotReport(spot.id, spot.lat, spot.lon, spot.temperature))
            log.info("thermal camera: %s", text)
            m.texts.append((MAV.MAV_SEVERITY_NOTICE, text))
        conn = self._conn
        assert conn is not None
        for severity, text in m.texts:
            conn.send(conn.conn.mav.statustext_encode(severity, text[:50].encode()))
        m.texts.clear()
        for seq in m.reached:
            conn.send(conn.conn.mav.mission_item_reached_encode(seq))
        m.reached.clear()

    def _send_due(self, now: float, intervals: dict[int, float]) -> None:
        for msg_id, default in self.rates.items():
            period = intervals.get(msg_id, default)
            due = self._due.get(msg_id, 0.0)
            if now >= due:  # keep the rate on a coarse loop, unless far behind
                self._due[msg_id] = due + period if now - due < period else now + period
                self._send_message(msg_id, periodic=True)

    def _send_message(self, msg_id: int, periodic: bool = False) -> bool:
        """Send one message by id now; False if the vehicle cannot produce it."""
        msg = self._encode(msg_id, periodic)
        if msg is False:
            return False
        if msg is not None:
            assert self._conn is not None
            self._conn.send(msg)
        return True

    def _encode(self, msg_id: int, periodic: bool) -> Any:
        """The message `msg_id` (None: nothing to say right now; False: unknown)."""
        assert self._conn is not None
        mav, m = self._conn.conn.mav, self.model
        boot_ms = int(self._sim_time * 1000) & 0xFFFFFFFF
        if msg_id == MAV.MAVLINK_MSG_ID_HEARTBEAT:
            flags = MAV.MAV_MODE_FLAG_CUSTOM_MODE_ENABLED | MAV.MAV_MODE_FLAG_STABILIZE_ENABLED
            if m.mode in (GUIDED, AUTO):
                flags |= MAV.MAV_MODE_FLAG_GUIDED_ENABLED
            if m.armed:
                flags |= MAV.MAV_MODE_FLAG_SAFETY_ARMED
            status = MAV.MAV_STATE_ACTIVE if m.armed else MAV.MAV_STATE_STANDBY
            if self.failsafe.active:
                status = MAV.MAV_STATE_CRITICAL  # as ArduCopter while any failsafe is on
            return mav.heartbeat_encode(MAV.MAV_TYPE_QUADROTOR, MAV.MAV_AUTOPILOT_ARDUPILOTMEGA,
                                        flags, m.mode, status)
        if msg_id == MAV.MAVLINK_MSG_ID_GLOBAL_POSITION_INT:
            vn, ve, vd = m.velocity
            return mav.global_position_int_encode(
                boot_ms, round(m.lat * 1e7), round(m.lon * 1e7),
                round((m.home_alt + m.alt) * 1000), round(m.alt * 1000),
                round(vn * 100), round(ve * 100), round(vd * 100), round(m.heading * 100) % 36000)
        if msg_id == MAV.MAVLINK_MSG_ID_SYS_STATUS:
            volts = 14.0 + 2.8 * m.battery_pct / 100.0
            current_ca = 0 if not m.armed else (100 if m.landed else 2500)
            return mav.sys_status_encode(SENSORS, SENSORS, SENSORS | MAV.MAV_SYS_STATUS_GEOFENCE,
                                         100, round(volts * 1000), current_ca,
                                         round(m.battery_pct), 0, 0, 0, 0, 0, 0)
        if msg_id == MAV.MAVLINK_MSG_ID_VFR_HUD:
            speed = (m.velocity[0] ** 2 + m.velocity[1] ** 2) ** 0.5
            throttle = 50 if m.armed and not m.landed else 0
            return mav.vfr_hud_encode(speed, speed, round(m.heading) % 360, throttle,
                                      m.home_alt + m.alt, -m.velocity[2])
        if msg_id == MAV.MAVLINK_MSG_ID_EXTENDED_SYS_STATE:
            landed = MAV.MAV_LANDED_STATE_ON_GROUND if m.landed else MAV.MAV_LANDED_STATE_IN_AIR
            return mav.extended_sys_state_encode(MAV.MAV_VTOL_STATE_MC, landed)
        if msg_id == MAV.MAVLINK_MSG_ID_MISSION_CURRENT:
            if periodic and not m.mission:
                return None
            return mav.mission_current_encode(m.mission_seq, max(0, len(m.mission) - 1))
        if msg_id == MAV.MAVLINK_MSG_ID_POSITION_TARGET_GLOBAL_INT:
            if m.mode != GUIDED or m.target is None:
                return None
            lat, lon, alt = m.target
            return mav.position_target_global_int_encode(
                boot_ms, MAV.MAV_FRAME_GLOBAL_RELATIVE_ALT_INT, 0xFF8, round(lat * 1e7),
                round(lon * 1e7), alt, 0, 0, 0, 0, 0, 0, 0, 0)
        if msg_id == MAV.MAVLINK_MSG_ID_HOME_POSITION:
            return mav.home_position_encode(round(m.home_lat * 1e7), round(m.home_lon * 1e7),
                                            round(m.home_alt * 1000), 0, 0, 0, [1, 0, 0, 0],
                                            0, 0, 0)
        if msg_id == MAV.MAVLINK_MSG_ID_AUTOPILOT_VERSION:
            caps = (MAV.MAV_PROTOCOL_CAPABILITY_MISSION_INT | MAV.MAV_PROTOCOL_CAPABILITY_MAVLINK2
                    | MAV.MAV_PROTOCOL_CAPABILITY_SET_POSITION_TARGET_GLOBAL_INT
                    | MAV.MAV_PROTOCOL_CAPABILITY_COMMAND_INT)
            return mav.autopilot_version_encode(caps, 0x04050000, 0, 0, 0, [0] * 8, [0] * 8,
                                                [0] * 8, 0, 0, self.sysid)
        return False


# -- command line ----------------------------------------------------------------------------
def _home(text: str) -> tuple[float, float, float]:
    parts = [p.strip() for p in text.split(",")]
    if len(parts) not in (2, 3):
        raise argparse.ArgumentTypeError("expected LAT,LON[,ALT]")
    try:
        values = [float(p) for p in parts]
    except ValueError as exc:
        raise argparse.ArgumentTypeError(str(exc)) from None
    return values[0], values[1], values[2] if len(values) == 3 else 0.0


def configure(parser: argparse.ArgumentParser) -> None:
    """Add the simulated UAV's options to `parser`."""
    parser.add_argument("--out", default="udpout:127.0.0.1:14550",
                        help="pymavlink connection string (default udpout:127.0.0.1:14550)")
    parser.add_argument("--sysid", type=int, default=1, help="MAVLink system id (default 1)")
    parser.add_argument("--home", type=_home, default=DEFAULT_HOME,
                        help="home LAT,LON[,ALT] (write --home=... when LAT is negative)")
    parser.add_argument("--hotspots", default="",
                        help="hidden hotspots: a file (JSON or LAT,LON lines) or LAT,LON;...")
    parser.add_argument("--camera-radius", type=float, default=25.0,
                        help="thermal camera footprint radius in metres (default 25)")
    parser.add_argument("--speedup", type=float, default=1.0,
                        help="simulated seconds per wall-clock second (default 1)")
    parser.add_argument("--failsafe", default=None,
                        help="GCS failsafe: hold (BRAKE), rtl or stop (LAND); default off "
                             "(a ground station may set FS_GCS_ENABLE)")
    parser.add_argument("--failsafe-timeout", type=float, default=None,
                        help="seconds without a GCS heartbeat before the failsafe (default 5)")
    parser.add_argument("--signing-key", default=None, metavar="FILE",
                        help="MAVLink 2 signing: a key file of 64 hex characters; sign "
                             "everything sent, refuse what is not signed with it")


def run(args: argparse.Namespace) -> int:
    """Run the simulated UAV until SIGINT/SIGTERM; returns the exit code."""
    from mrss.errors import ConfigError

    logging.basicConfig(level=logging.INFO, format="%(asctime)s %(name)s %(message)s")
    try:
        hotspots = parse_hotspots(args.hotspots)
        key = None if args.signing_key is None else load_key(args.signing_key,
                                                             key="--signing-key")
        uav = SimUav(args.out, sysid=args.sysid, home=args.home, hotspots=hotspots,
                     speedup=args.speedup, camera_radius_m=args.camera_radius,
                     failsafe=parse_policy(args.failsafe, args.failsafe_timeout,
                                           keys=CLI_FAILSAFE_KEYS), signing_key=key)
    except (ConfigError, ValueError) as exc:
        print(f"mrss sim uav: {exc}", file=sys.stderr)
        return 2

    def stop(signum: int, frame: FrameType | None) -> None:
        uav.stop()

    signal.signal(signal.SIGTERM, stop)
    signal.signal(signal.SIGINT, stop)
    uav.run()
    return 0


def main(argv: Sequence[str] | None = None) -> int:
    """Entry point of ``python -m mrss.sim.uav``."""
    parser = argparse.ArgumentParser(prog="mrss sim uav", description=__doc__)
    configure(parser)
    return run(parser.parse_args(argv))


if __name__ == "__main__":
    sys.exit(main())
