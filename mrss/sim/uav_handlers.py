"""How the simulated UAV answers a ground station's messages, as ArduCopter does.

Every COMMAND_LONG / COMMAND_INT gets a COMMAND_ACK; unknown commands get
MAV_RESULT_UNSUPPORTED and unknown messages are ignored, so no input stops the vehicle.
"""

from __future__ import annotations

import logging
import time
from collections.abc import Callable
from typing import Any

from mrss.links.mavconn import MAV
from mrss.sim.copter import AUTO, FORCE_DISARM_MAGIC, GUIDED, LAND, RTL, CopterModel, Refused
from mrss.sim.gcs_failsafe import GcsFailsafe
from mrss.sim.mission_server import MissionServer
from mrss.sim.uav_params import UavParams

log = logging.getLogger("mrss.sim.uav")

POSITION_IGNORED = 0b111  # type_mask bits: lat/lon/alt not set


class UavHandlers:
    """Dispatches incoming MAVLink messages to the model, the mission server, the params."""

    def __init__(self, mav: Any, send: Callable[[Any], None], model: CopterModel,
                 mission: MissionServer, params: UavParams, sysid: int,
                 send_now: Callable[[int], bool], failsafe: GcsFailsafe) -> None:
        self.mav = mav
        self.send = send
        self.model = model
        self.mission = mission
        self.params = params
        self.sysid = sysid
        self.send_now = send_now  # send a message by id on request; False if unknown
        self.failsafe = failsafe
        self.intervals: dict[int, float] = {}  # msg id -> seconds, from SET_MESSAGE_INTERVAL

    def handle(self, msg: Any) -> None:
        """Answer one message; a message for another system is ignored."""
        target = getattr(msg, "target_system", 0)
        if target not in (0, self.sysid):
            return
        kind = msg.get_type()
        try:
            if kind == "HEARTBEAT":
                if msg.type == MAV.MAV_TYPE_GCS:
                    self.failsafe.heard(msg.get_srcSystem(), time.monotonic())
            elif kind == "COMMAND_LONG":
                self._command(msg, msg.command, (msg.param1, msg.param2, msg.param3,
                              msg.param4, msg.param5, msg.param6, msg.param7), None)
            elif kind == "COMMAND_INT":
                self._command(msg, msg.command, (msg.param1, msg.param2, msg.param3,
                              msg.param4, msg.x, msg.y, msg.z), msg.frame)
            elif kind == "SET_MODE":
                result = self._set_mode(msg.base_mode, msg.custom_mode)
                self._ack(msg, MAV.MAV_CMD_DO_SET_MODE, result)
            elif kind == "SET_POSITION_TARGET_GLOBAL_INT":
                self._position_target(msg)
            elif kind.startswith("PARAM_"):
                self._param(msg, kind)
            elif not self.mission.handle(msg):
                log.debug("ignored %s", kind)
        except (AttributeError, TypeError, ValueError, OverflowError) as exc:
            log.warning("bad %s message ignored: %s", kind, exc)

    # -- commands --------------------------------------------------------------------------
    def _ack(self, msg: Any, command: int, result: int) -> None:
        self.send(self.mav.command_ack_encode(command, result, 0, 0, msg.get_srcSystem(),
                                              msg.get_srcComponent()))

    def _refusal(self, exc: Refused) -> int:
        # Said at once, before the COMMAND_ACK, as ArduPilot does: the GCS shows why.
        self.send(self.mav.statustext_encode(MAV.MAV_SEVERITY_WARNING, exc.text[:50].encode()))
        return exc.result

    def _set_mode(self, base_mode: float, custom_mode: float) -> int:
        if not int(base_mode) & MAV.MAV_MODE_FLAG_CUSTOM_MODE_ENABLED:
            return int(MAV.MAV_RESULT_UNSUPPORTED)
        try:
            self.model.set_mode(int(custom_mode))
        except Refused as exc:
            return self._refusal(exc)
        return int(MAV.MAV_RESULT_ACCEPTED)

    def _command(self, msg: Any, command: int, p: tuple[float, ...], frame: int | None) -> None:
        try:
            result = self._run_command(command, p, frame)
        except Refused as exc:
            result = self._refusal(exc)
        self._ack(msg, command, result)

    def _run_command(self, command: int, p: tuple[float, ...], frame: int | None) -> int:
        model = self.model
        accepted = int(MAV.MAV_RESULT_ACCEPTED)
        if command == MAV.MAV_CMD_COMPONENT_ARM_DISARM:
            if p[0] == 1:
                model.arm()
            else:
                model.disarm(force=int(p[1]) == FORCE_DISARM_MAGIC)
        elif command == MAV.MAV_CMD_DO_SET_MODE:
            return self._set_mode(p[0], p[1])
        elif command == MAV.MAV_CMD_NAV_TAKEOFF:
            model.takeoff(p[6])
        elif command == MAV.MAV_CMD_NAV_RETURN_TO_LAUNCH:
            model.set_mode(RTL)
        elif command == MAV.MAV_CMD_NAV_LAND:
            model.set_mode(LAND)
        elif command == MAV.MAV_CMD_MISSION_START:
            if 0 < int(p[0]) < len(model.mission):
                model.mission_seq = int(p[0])
            model.set_mode(AUTO)
        elif command == MAV.MAV_CMD_DO_SET_MISSION_CURRENT:
            self.mission.set_current(int(p[0]))
        elif command == MAV.MAV_CMD_DO_CHANGE_SPEED:
            if p[1] <= 0:
                return int(MAV.MAV_RESULT_DENIED)
            model.params.speed_mps = p[1]
        elif command == MAV.MAV_CMD_DO_REPOSITION and frame is not None:
            if int(p[1]) & MAV.MAV_DO_REPOSITION_FLAGS_CHANGE_MODE and model.mode != GUIDED:
                model.set_mode(GUIDED)
            alt = model.relative_alt(frame, p[6]) if p[6] else model.alt
            model.goto(p[4] * 1e-7, p[5] * 1e-7, alt)
        elif command == MAV.MAV_CMD_REQUEST_MESSAGE:
            return accepted if self.send_now(int(p[0])) else int(MAV.MAV_RESULT_UNSUPPORTED)
        elif command == MAV.MAV_CMD_REQUEST_AUTOPILOT_CAPABILITIES:
            self.send_now(MAV.MAVLINK_MSG_ID_AUTOPILOT_VERSION)
        elif command == MAV.MAV_CMD_GET_HOME_POSITION:
            self.send_now(MAV.MAVLINK_MSG_ID_HOME_POSITION)
        elif command == MAV.MAV_CMD_SET_MESSAGE_INTERVAL:
            self._set_interval(int(p[0]), p[1])
        else:
            return int(MAV.MAV_RESULT_UNSUPPORTED)
        return accepted

    def _set_interval(self, msg_id: int, interval_us: float) -> None:
        if interval_us > 0:
            self.intervals[msg_id] = interval_us / 1e6
        elif interval_us == -1:
            self.intervals[msg_id] = float("inf")  # disabled
        else:
            self.intervals.pop(msg_id, None)  # back to the default rate

    def _position_target(self, msg: Any) -> None:
        if msg.type_mask & POSITION_IGNORED == POSITION_IGNORED:
            self.model.texts.append((MAV.MAV_SEVERITY_WARNING,
                                     "Guided: only position targets are simulated"))
            return
        try:
            self.model.goto(msg.lat_int * 1e-7, msg.lon_int * 1e-7,
                            self.model.relative_alt(msg.coordinate_frame, msg.alt))
        except Refused as exc:
            self._refusal(exc)
            return
        self.send_now(MAV.MAVLINK_MSG_ID_POSITION_TARGET_GLOBAL_INT)

    # -- parameters ------------------------------------------------------------------------
    def _param(self, msg: Any, kind: str) -> None:
        if kind == "PARAM_REQUEST_LIST":
            for index in range(len(self.params)):
                self._send_param(index)
        elif kind == "PARAM_REQUEST_READ":
            wanted: int | None = msg.param_index
            if msg.param_index < 0:
                wanted = self.params.index_of(_param_name(msg.param_id))
            if wanted is not None:
                self._send_param(wanted)
        elif kind == "PARAM_SET":
            name = _param_name(msg.param_id)
            if self.params.set(name, msg.param_value):
                log.info("param %s set to %s", name, msg.param_value)
            found = self.params.index_of(name)
            if found is not None:
                self._send_param(found)  # the value now in force, as ArduPilot echoes it

    def _send_param(self, index: int) -> None:
        entry = self.params.at(index)
        if entry is None:
            return
        name, value = entry
        self.send(self.mav.param_value_encode(name.encode(), value,
                                              MAV.MAV_PARAM_TYPE_REAL32, len(self.params), index))


def _param_name(raw: str | bytes) -> str:
    text = raw.decode("ascii", "replace") if isinstance(raw, bytes) else raw
    return text.rstrip("\x00")
