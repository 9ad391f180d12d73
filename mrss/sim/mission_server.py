"""The vehicle side of the MAVLink mission protocol: upload, download, clear, set current.

Upload: MISSION_COUNT -> MISSION_REQUEST_INT(0) -> MISSION_ITEM_INT(0) -> ... ->
MISSION_ACK. A lost item is requested again after `retry_s`; after `max_retries` the
transfer is cancelled. As in ArduPilot, item 0 is home and is not flown.
"""

from __future__ import annotations

import logging
import time
from collections.abc import Callable
from typing import Any

from mrss.links.mavconn import MAV
from mrss.sim.copter import CopterModel, NavItem, Refused

log = logging.getLogger("mrss.sim.mission")


class MissionServer:
    """Answers a ground station's mission messages for one simulated vehicle."""

    def __init__(self, mav: Any, send: Callable[[Any], None], model: CopterModel,
                 retry_s: float = 0.5, max_retries: int = 5) -> None:
        self.mav = mav
        self.send = send
        self.model = model
        self.retry_s = retry_s
        self.max_retries = max_retries
        self._incoming: list[NavItem | None] | None = None
        self._peer = (0, 0)
        self._use_int = True
        self._last_request = 0.0
        self._retries = 0

    @property
    def receiving(self) -> bool:
        """Whether an upload is in progress."""
        return self._incoming is not None

    def handle(self, msg: Any) -> bool:
        """Process `msg` if it is a mission message; return whether it was one."""
        kind = msg.get_type()
        peer = (msg.get_srcSystem(), msg.get_srcComponent())
        if kind == "MISSION_COUNT":
            self._start_upload(msg, peer)
        elif kind in ("MISSION_ITEM_INT", "MISSION_ITEM"):
            self._receive_item(msg, kind == "MISSION_ITEM_INT")
        elif kind == "MISSION_REQUEST_LIST":
            count = len(self.model.mission) or 1
            self.send(self.mav.mission_count_encode(*peer, count, msg.mission_type))
        elif kind in ("MISSION_REQUEST_INT", "MISSION_REQUEST"):
            self._send_item(msg.seq, peer, kind == "MISSION_REQUEST_INT")
        elif kind == "MISSION_CLEAR_ALL":
            self.model.mission = []
            self.model.mission_seq = 0
            self.send(self.mav.mission_ack_encode(*peer, MAV.MAV_MISSION_ACCEPTED))
        elif kind == "MISSION_SET_CURRENT":
            self.set_current(msg.seq)
        elif kind == "MISSION_ACK":
            pass  # the end of a download; nothing to do
        else:
            return False
        return True

    def set_current(self, seq: int) -> None:
        """Make `seq` the next item to fly and announce it."""
        if 0 < seq < len(self.model.mission):
            self.model.mission_seq = seq
        self.send(self.mav.mission_current_encode(self.model.mission_seq,
                                                  max(0, len(self.model.mission) - 1)))

    def tick(self, now: float | None = None) -> None:
        """Repeat a lost request, or give up on a stalled upload."""
        if self._incoming is None:
            return
        now = time.monotonic() if now is None else now
        if now - self._last_request < self.retry_s:
            return
        self._retries += 1
        if self._retries > self.max_retries:
            log.warning("mission upload from %s stalled; cancelled", self._peer)
            self._incoming = None
            self.send(self.mav.mission_ack_encode(*self._peer,
                                                  MAV.MAV_MISSION_OPERATION_CANCELLED))
            return
        self._request_next()

    def _start_upload(self, msg: Any, peer: tuple[int, int]) -> None:
        if msg.mission_type != MAV.MAV_MISSION_TYPE_MISSION:
            # Fences and rally points are not simulated.
            self.send(self.mav.mission_ack_encode(*peer, MAV.MAV_MISSION_UNSUPPORTED,
                                                  msg.mission_type))
            return
        self._peer = peer
        if msg.count == 0:
            self.model.mission = []
            self.model.mission_seq = 0
            self._incoming = None
            self.send(self.mav.mission_ack_encode(*peer, MAV.MAV_MISSION_ACCEPTED))
            return
        self._incoming = [None] * msg.count
        self._use_int = True
        self._retries = 0
        self._request_next()

    def _request_next(self) -> None:
        assert self._incoming is not None
        seq = self._incoming.index(None)
        encode = self.mav.mission_request_int_encode if self._use_int \
            else self.mav.mission_request_encode
        self.send(encode(*self._peer, seq))
        self._last_request = time.monotonic()

    def _receive_item(self, msg: Any, is_int: bool) -> None:
        if msg.current == 2 and self._incoming is None:
            self._guided_goto(msg, is_int)
            return
        if self._incoming is None or msg.mission_type != MAV.MAV_MISSION_TYPE_MISSION:
            return
        expected = self._incoming.index(None)
        if msg.seq != expected:
            self._request_next()  # out of order (a duplicate or a loss): ask again
            return
        scale = 1e-7 if is_int else 1.0
        self._incoming[msg.seq] = NavItem(
            seq=msg.seq, command=msg.command, frame=msg.frame,
            params=(msg.param1, msg.param2, msg.param3, msg.param4),
            lat=msg.x * scale, lon=msg.y * scale, alt=msg.z,
        )
        self._use_int = is_int
        self._retries = 0
        if None in self._incoming:
            self._request_next()
            return
        self.model.mission = [item for item in self._incoming if item is not None]
        self.model.mission_seq = 1 if len(self.model.mission) > 1 else 0
        self._incoming = None
        log.info("mission of %d items received", len(self.model.mission))
        self.send(self.mav.mission_ack_encode(*self._peer, MAV.MAV_MISSION_ACCEPTED))

    def _guided_goto(self, msg: Any, is_int: bool) -> None:
        """ArduPilot's "guided mode waypoint": a MISSION_ITEM with current=2."""
        scale = 1e-7 if is_int else 1.0
        peer = (msg.get_srcSystem(), msg.get_srcComponent())
        try:
            self.model.goto(msg.x * scale, msg.y * scale,
                            self.model.relative_alt(msg.frame, msg.z))
        except Refused as exc:
            self.model.texts.append((MAV.MAV_SEVERITY_WARNING, exc.text))
            self.send(self.mav.mission_ack_encode(*peer, MAV.MAV_MISSION_ERROR))
            return
        self.send(self.mav.mission_ack_encode(*peer, MAV.MAV_MISSION_ACCEPTED))

    def _send_item(self, seq: int, peer: tuple[int, int], as_int: bool) -> None:
        model = self.model
        if seq == 0 and not model.mission:
            item = NavItem(0, MAV.MAV_CMD_NAV_WAYPOINT, MAV.MAV_FRAME_GLOBAL,
                           lat=model.home_lat, lon=model.home_lon, alt=model.home_alt)
        elif 0 <= seq < len(model.mission):
            item = model.mission[seq]
        else:
            self.send(self.mav.mission_ack_encode(*peer, MAV.MAV_MISSION_INVALID_SEQUENCE))
            return
        if seq == 0:
            item = NavItem(0, item.command, MAV.MAV_FRAME_GLOBAL, item.params,
                           model.home_lat, model.home_lon, model.home_alt)
        if as_int:
            self.send(self.mav.mission_item_int_encode(
                *peer, seq, item.frame, item.command, int(seq == model.mission_seq), 1,
                *item.params, round(item.lat * 1e7), round(item.lon * 1e7), item.alt))
        else:
            self.send(self.mav.mission_item_encode(
                *peer, seq, item.frame, item.command, int(seq == model.mission_seq), 1,
                *item.params, item.lat, item.lon, item.alt))
