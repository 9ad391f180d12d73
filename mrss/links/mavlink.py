"""The MAVLink robot link: commands and telemetry of one ArduCopter-style vehicle.

One idea in one module (~420 lines): the link's face, what a skill calls; the protocol's
parts are modules of their own (mavlink_commands, _mission, _telemetry, _failsafe,
_signing, mavconn).

Blocking command helpers (`arm`, `set_mode`, `takeoff`, `goto`, `land`, ...) may be
called from any thread; they retry unanswered commands (mrss.links.mavlink_commands)
and raise LinkDown, CommandRejected or CommandTimeout (mrss.links.errors). The link is
up while heartbeats arrive and goes down after `heartbeat_timeout` seconds without one.
A UDP link has no thread of its own: the process's shared link loop (mrss.links.timers)
reads its socket and runs its duties (GCS heartbeat, heartbeat timeout); a stream (TCP,
serial) has one.

Failsafe (mrss.links.failsafe): the link is the vehicle's GCS. It sends a GCS heartbeat
every second while its controller lives (`watch_controller`), sets FS_GCS_ENABLE and
FS_GCS_TIMEOUT on every connect when a `failsafe` is declared, and when the vehicle
says it took its GCS failsafe (``GCS Failsafe...``, or ``GCS Failsafe Cleared`` for one
it missed) reports it down with a ``failsafe:`` reason until the vehicle hears it again.
"""

from __future__ import annotations

import queue
import threading
import time
from collections.abc import Sequence
from typing import Any

from mrss.links.ardupilot import mode_name, mode_number, parse_hotspot
from mrss.links.base import LinkStateCallback, RobotLink, TelemetryCallback
from mrss.links.errors import CommandRejected, CommandTimeout, LinkError
from mrss.links.failsafe import CONTROLLER_HEARTBEAT_S, FailsafeEvent, FailsafePolicy
from mrss.links.geo import distance_m
from mrss.links.mavconn import MAV, MavConnection, text_of
from mrss.links.mavlink_commands import DEFAULT_PROGRESS_TIMEOUT_S, CommandExchange
from mrss.links.mavlink_failsafe import VehicleFailsafe
from mrss.links.mavlink_mission import MISSION_REPLIES, MissionItem, MissionUpload
from mrss.links.mavlink_signing import down_reason
from mrss.links.mavlink_telemetry import telemetry_of
from mrss.links.timers import TIMERS, TimerHandle

GCS_HEARTBEAT_S = CONTROLLER_HEARTBEAT_S
POSITION_ONLY = 0xFF8  # SET_POSITION_TARGET type_mask: use lat/lon/alt, ignore the rest
REFUSAL_CHECK_S = 0.5
READ_BATCH = 64         # messages read per turn of the shared loop (then other links)
TICK_SLACK_S = 0.01     # a duty runs this long after its deadline (never a busy loop)
FAILSAFE_TICK_S = 0.1   # how often PARAM_SETs are looked at while some are unconfirmed


class MavlinkLink(RobotLink):
    """A link to one MAVLink vehicle over a pymavlink connection (default: UDP in)."""

    kind = "mavlink"

    def __init__(
        self, robot_id: str, url: str = "udpin:127.0.0.1:14550", *,
        target_system: int | None = None, heartbeat_timeout: float = 3.0,
        command_timeout: float = 1.0, retries: int = 3,
        progress_timeout: float = DEFAULT_PROGRESS_TIMEOUT_S,
        on_link_state: LinkStateCallback | None = None,
        on_telemetry: TelemetryCallback | None = None,
        failsafe: FailsafePolicy | None = None, signing_key: bytes | None = None,
    ) -> None:
        super().__init__(robot_id, on_link_state=on_link_state, on_telemetry=on_telemetry,
                         failsafe=failsafe)
        self.url = url
        self.target_system = target_system
        self.heartbeat_timeout = heartbeat_timeout
        self.command_timeout = command_timeout
        self.retries = retries
        self.progress_timeout = progress_timeout
        self.signing_key = signing_key
        self.mode: str | None = None
        self.armed = False
        self.landed: bool | None = None
        self.position_target: tuple[float, float, float] | None = None
        self._conn: MavConnection | None = None
        self._thread: threading.Thread | None = None  # a stream's own receive thread
        self._ticker: TimerHandle | None = None  # UDP: duties on the shared link loop
        self._failsafe_ticking = False
        self._stop = threading.Event()
        self._last_heartbeat: float | None = None
        self._next_gcs_heartbeat = 0.0
        self._command_lock = threading.Lock()  # one exchange at a time: command, mission
        self._commands = CommandExchange(robot_id, self._send_command, self.require_up)
        self._mission_replies: queue.Queue[Any] = queue.Queue()
        self._reported: tuple[str | None, bool, bool | None] = (None, False, None)
        self._next_refusal_check = 0.0
        self._refusals_explained = 0
        self._failsafe = VehicleFailsafe(
            robot_id, failsafe, command_timeout, retries, send_param=self._send_param,
            record=self._failsafe_record, down=self._report_failsafe,
            up=lambda why: self._set_link_state(True, why), mode=lambda: self.mode,
            log=self.log)

    # -- life cycle ------------------------------------------------------------------------
    def start(self) -> None:
        """Open the connection and start receiving."""
        try:
            self._conn = MavConnection(self.url, source_system=255,
                                       source_component=MAV.MAV_COMP_ID_MISSIONPLANNER,
                                       udp_timeout=self.heartbeat_timeout,
                                       signing_key=self.signing_key, link_id=1,
                                       name=f"link {self.robot_id}", log=self.log)
        except (OSError, ValueError) as exc:
            raise LinkError(self.robot_id, f"cannot open {self.url}: {exc}") from exc
        self._set_link_state(False, "waiting for first heartbeat")
        if self._conn.datagrams:  # the shared link loop reads it and keeps its time
            name = f"mavlink-{self.robot_id}"
            TIMERS.add_reader(self._conn.socket, self._on_readable, name=name)
            self._ticker = TIMERS.schedule(self._tick, name=name)
            return
        self._thread = threading.Thread(target=self._receive_loop,
                                        name=f"mavlink-{self.robot_id}", daemon=True)
        self._thread.start()

    def close(self) -> None:
        """Stop receiving, close the socket; the link ends down ("link closed")."""
        self._stop.set()
        if self._ticker is not None and self._conn is not None:
            self._ticker.cancel()
            TIMERS.remove_reader(self._conn.socket)  # returns once no callback runs
        if self._thread is not None:
            self._thread.join(timeout=5)
        if self._conn is not None:
            self._conn.close()
        self._mark_closed()

    @property
    def signed(self) -> bool:
        """Whether the link signs its messages and refuses unsigned ones."""
        return self.signing_key is not None

    def refused(self) -> dict[str, int]:
        """Incoming messages refused under signing, by reason ({} without signing)."""
        return self._conn.refused() if self._conn is not None else {}

    # -- commands --------------------------------------------------------------------------
    def command(self, command: int, *params: float, timeout: float | None = None) -> int:
        """Send a COMMAND_LONG until acknowledged; return the MAV_RESULT if ACCEPTED."""
        timeout = self.command_timeout if timeout is None else timeout
        with self._command_lock:
            return self._commands.run(command, params, timeout, self.retries,
                                      self.progress_timeout)

    def arm(self) -> None:
        """Arm the motors (the vehicle must be in an armable mode, e.g. GUIDED)."""
        self.command(MAV.MAV_CMD_COMPONENT_ARM_DISARM, 1)
        self.armed = True

    def disarm(self, force: bool = False) -> None:
        """Disarm; `force` disarms even in flight (the vehicle falls)."""
        self.command(MAV.MAV_CMD_COMPONENT_ARM_DISARM, 0, 21196 if force else 0)
        self.armed = False

    def set_mode(self, name: str) -> None:
        """Switch to an ArduCopter mode by name (GUIDED, AUTO, LOITER, RTL, LAND, ...)."""
        try:
            number = mode_number(name)
        except KeyError:
            raise ValueError(f"unknown ArduCopter mode {name!r}") from None
        self.command(MAV.MAV_CMD_DO_SET_MODE, MAV.MAV_MODE_FLAG_CUSTOM_MODE_ENABLED, number)
        self.mode = mode_name(number)

    def takeoff(self, alt_m: float) -> None:
        """Start climbing to `alt_m` above home (GUIDED and armed); returns once accepted."""
        self.command(MAV.MAV_CMD_NAV_TAKEOFF, 0, 0, 0, 0, 0, 0, alt_m)
        self.landed = False

    def land(self) -> None:
        """Land where the vehicle is (LAND mode)."""
        self.command(MAV.MAV_CMD_NAV_LAND)
        self.mode = "LAND"

    def return_to_launch(self) -> None:
        """Fly home and land (RTL mode)."""
        self.command(MAV.MAV_CMD_NAV_RETURN_TO_LAUNCH)
        self.mode = "RTL"

    def go_home(self) -> None:
        """What a stand-down by area (mode home) asks of any link: RTL."""
        self.return_to_launch()

    def start_mission(self, first_item: int = 0) -> None:
        """Fly the uploaded mission (AUTO), from `first_item` if it is not 0."""
        self.command(MAV.MAV_CMD_MISSION_START, first_item, 0)
        self.mode = "AUTO"

    def goto(self, lat: float, lon: float, alt_m: float) -> None:
        """Set a GUIDED position target; returns once the vehicle reports it as its target."""
        self.require_up()
        if self.mode != "GUIDED":
            raise CommandRejected(self.robot_id, "goto", f"mode is {self.mode}, needs GUIDED")
        if self.landed:
            raise CommandRejected(self.robot_id, "goto", "vehicle is on the ground")
        msg = self._mav().set_position_target_global_int_encode(
            0, self._target(), 1, MAV.MAV_FRAME_GLOBAL_RELATIVE_ALT_INT, POSITION_ONLY,
            round(lat * 1e7), round(lon * 1e7), alt_m, 0, 0, 0, 0, 0, 0, 0, 0)

        def accepted() -> bool:
            t = self.position_target
            return t is not None and abs(t[0] - lat) < 2e-7 and abs(t[1] - lon) < 2e-7 \
                and abs(t[2] - alt_m) < 0.05

        for _ in range(self.retries):
            self._send(msg)
            try:
                self.wait_for(accepted, self.command_timeout, "goto")
                return
            except CommandTimeout:
                continue
        raise CommandTimeout(self.robot_id, "goto", self.command_timeout, self.retries)

    def upload_mission(self, items: Sequence[MissionItem]) -> None:
        """Replace the vehicle's mission with `items` (home is added as item 0)."""
        self.require_up()
        home = (0.0, 0.0)
        position = self.latest("position")
        if position is not None:
            home = (position["lat"], position["lon"])
        upload = MissionUpload(self.robot_id, self._mav(), self._send, self._mission_replies,
                               (self._target(), 1),
                               lambda: None if self.up else self.reason,
                               self.command_timeout, self.retries)
        with self._command_lock:
            upload.run(items, home)

    # -- waiting on telemetry --------------------------------------------------------------
    def wait_arrival(self, lat: float, lon: float, alt_m: float, *, tolerance_m: float = 2.0,
                     timeout: float = 120.0) -> None:
        """Block until the vehicle is within `tolerance_m` of a point (alt above home)."""
        def arrived() -> bool:
            p = self.latest("position")
            return p is not None and distance_m(p["lat"], p["lon"], lat, lon) <= tolerance_m \
                and abs(p["relative_alt"] - alt_m) <= tolerance_m
        self.wait_for(arrived, timeout, f"arrival at {lat:.6f},{lon:.6f},{alt_m:.0f}")

    def wait_landed(self, timeout: float = 120.0) -> None:
        """Block until the vehicle is on the ground and disarmed."""
        self.wait_for(lambda: bool(self.landed) and not self.armed, timeout, "landing")

    # -- receiving -------------------------------------------------------------------------
    def _mav(self) -> Any:
        if self._conn is None:
            raise RuntimeError("link not started")
        return self._conn.conn.mav

    def _send(self, msg: Any) -> None:
        if self._conn is not None:
            self._conn.send(msg)

    def _send_command(self, command: int, attempt: int, values: list[float]) -> None:
        self._send(self._mav().command_long_encode(self._target(), 1, command, attempt,
                                                   *values))

    def _target(self) -> int:
        return self.target_system or 1

    def _receive_loop(self) -> None:
        """A stream connection's own thread (UDP links use the shared loop instead)."""
        assert self._conn is not None
        previous, draining = time.monotonic(), False
        while not self._stop.is_set():
            msg = None
            try:
                msg = self._conn.recv(timeout=0.1)
                if msg is not None:
                    self._dispatch_message(msg)
            except Exception:
                self.log.exception("error handling a MAVLink message; continuing")
            now = time.monotonic()
            if now - previous > max(1.0, self.heartbeat_timeout / 2):
                draining = True  # this process was stalled: read what came meanwhile first
            draining = draining and msg is not None
            previous = now
            self._failsafe.tick(now)
            self._duties(now, draining)

    def _on_readable(self) -> None:
        """The shared loop: the socket is readable; handle what it holds (a batch)."""
        conn = self._conn
        if conn is None or self._stop.is_set():
            return
        # The records of what came together (a telemetry tick's messages) go out together.
        with self._sample_scope():
            for _ in range(READ_BATCH):
                msg = conn.recv(timeout=0)
                if msg is None:
                    return
                try:
                    self._dispatch_message(msg)
                except Exception:
                    self.log.exception("error handling a MAVLink message; continuing")

    def _tick(self) -> float | None:
        """The shared loop's job for this link: its duties, then the delay to the next
        (GCS heartbeat, heartbeat timeout, refusal check)."""
        conn = self._conn
        if conn is None or self._stop.is_set():
            return None
        now = time.monotonic()
        last = self._last_heartbeat
        # Data waiting (after a stall of this process, say) is read before a timeout; the
        # socket is looked at only when a timeout is due (not on every GCS heartbeat).
        due = self.up and last is not None and now - last > self.heartbeat_timeout
        self._duties(now, due and conn.pending())
        wake = min(self._next_gcs_heartbeat, now + self.heartbeat_timeout)
        if self.up and last is not None:
            wake = min(wake, last + self.heartbeat_timeout + TICK_SLACK_S)
        if not self.up and conn.signing is not None:
            wake = min(wake, self._next_refusal_check)
        return max(wake - now, TICK_SLACK_S)

    def _failsafe_tick(self) -> float | None:
        """The shared loop: PARAM_SETs of the failsafe while some are unconfirmed."""
        if self._stop.is_set() or not self._failsafe.busy:
            self._failsafe_ticking = False
            return None
        self._failsafe.tick(time.monotonic())
        return FAILSAFE_TICK_S

    def _duties(self, now: float, draining: bool) -> None:
        """What is due without a message: the GCS heartbeat, the refusals' explanation,
        the heartbeat timeout (not while `draining` what came during a stall)."""
        if now >= self._next_gcs_heartbeat:
            self._next_gcs_heartbeat = now + GCS_HEARTBEAT_S
            if self._controlled():
                self._send(self._mav().heartbeat_encode(
                    MAV.MAV_TYPE_GCS, MAV.MAV_AUTOPILOT_INVALID, 0, 0,
                    MAV.MAV_STATE_ACTIVE))
        self._explain_refusals(now)
        last = self._last_heartbeat
        if self.up and not draining and last is not None \
                and now - last > self.heartbeat_timeout:
            self._set_link_state(False, f"no heartbeat for {self.heartbeat_timeout:.1f} s")

    def _explain_refusals(self, now: float) -> None:
        """While no heartbeat comes, say in the down reason what signing refused."""
        conn = self._conn
        if self.up or conn is None or conn.signing is None or now < self._next_refusal_check:
            return
        self._next_refusal_check = now + REFUSAL_CHECK_S
        totals = conn.refused()
        reason = down_reason(self.reason, totals, self._refusals_explained)
        if reason is not None:
            self._refusals_explained = sum(totals.values())
            self._set_link_state(False, reason)

    def _dispatch_message(self, msg: Any) -> None:
        kind = msg.get_type()
        if kind == "HEARTBEAT":
            self._on_heartbeat(msg)
            return
        if kind == "STATUSTEXT" and self.target_system is None:
            self._failsafe.on_text(text_of(msg))  # may come before the first heartbeat
            return
        if self.target_system is None or msg.get_srcSystem() != self.target_system:
            return
        if kind == "COMMAND_ACK":
            self._commands.acked(msg.command, msg.result)
        elif kind in MISSION_REPLIES:
            self._mission_replies.put(msg)
        elif kind == "POSITION_TARGET_GLOBAL_INT":
            self.position_target = (msg.lat_int * 1e-7, msg.lon_int * 1e-7, msg.alt)
            self._notify()
        elif kind == "EXTENDED_SYS_STATE":
            self._update_status(self.mode, self.armed,
                                msg.landed_state == MAV.MAV_LANDED_STATE_ON_GROUND)
        elif kind == "STATUSTEXT":
            self._on_text(msg)
        elif kind == "PARAM_VALUE":
            self._failsafe.on_param(text_of(msg, "param_id"), float(msg.param_value))
        else:
            converted = telemetry_of(msg)
            if converted is not None:
                self._publish_telemetry(*converted)

    def _on_heartbeat(self, msg: Any) -> None:
        if msg.type == MAV.MAV_TYPE_GCS or msg.autopilot == MAV.MAV_AUTOPILOT_INVALID:
            return  # another ground station, not a vehicle
        if self.target_system is None:
            self.target_system = msg.get_srcSystem()
        if msg.get_srcSystem() != self.target_system:
            return
        was_seen = self._last_heartbeat is not None
        self._last_heartbeat = time.monotonic()
        armed = bool(msg.base_mode & MAV.MAV_MODE_FLAG_SAFETY_ARMED)
        self._update_status(mode_name(msg.custom_mode), armed, self.landed)
        if self._failsafe.on_heartbeat(msg.system_status == MAV.MAV_STATE_CRITICAL):
            return
        if not self.up:
            what = "heartbeat resumed" if was_seen else "heartbeat"
            if self._set_link_state(True, f"{what} from system {self.target_system}"):
                self._failsafe.connected()
                if self._ticker is not None and self._failsafe.busy \
                        and not self._failsafe_ticking:
                    self._failsafe_ticking = True
                    TIMERS.schedule(self._failsafe_tick, name=f"mavlink-{self.robot_id}-fs")

    def _on_text(self, msg: Any) -> None:
        text = text_of(msg)
        self._failsafe.on_text(text)
        spot = parse_hotspot(text)
        if spot is not None:
            self._publish_telemetry("hotspot", {"id": spot.id, "lat": spot.lat,
                                                "lon": spot.lon,
                                                "temperature": spot.temperature})
            return
        if msg.severity <= MAV.MAV_SEVERITY_WARNING:
            self._commands.warned(text)
        self._publish_telemetry("text", {"severity": msg.severity, "text": text})

    # -- failsafe (mrss.links.mavlink_failsafe) ---------------------------------------------
    def _send_param(self, name: str, value: float) -> None:
        if self._conn is not None:
            self._send(self._mav().param_set_encode(
                self._target(), 1, name.encode(), value, MAV.MAV_PARAM_TYPE_REAL32))

    def _failsafe_record(self, event: FailsafeEvent, detail: str) -> None:
        action = self.failsafe.action.value if self.failsafe else None
        self._publish_telemetry("failsafe", {"event": event.value, "action": action,
                                             "mode": self.mode, "detail": detail})

    def _update_status(self, mode: str | None, armed: bool, landed: bool | None) -> None:
        """Take the vehicle's reported state; publish a status record when it changed."""
        reported = (mode, armed, landed)
        if reported == self._reported:
            return
        self._reported = reported
        self.mode, self.armed, self.landed = reported
        self._publish_telemetry("status", {"mode": mode, "armed": armed, "landed": landed})
