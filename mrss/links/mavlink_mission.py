"""The ground side of the MAVLink mission upload protocol, used by `MavlinkLink`.

MISSION_COUNT -> (MISSION_REQUEST_INT n -> MISSION_ITEM_INT n)* -> MISSION_ACK.
Lost messages are repeated after `step_timeout`; a refusal raises CommandRejected.
"""

from __future__ import annotations

import queue
import time
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from typing import Any

from mrss.links.errors import CommandRejected, CommandTimeout, LinkDown
from mrss.links.mavconn import MAV

MISSION_REPLIES = ("MISSION_REQUEST_INT", "MISSION_REQUEST", "MISSION_ACK")


@dataclass(frozen=True)
class MissionItem:
    """One mission item; altitudes in metres above home, as ArduCopter flies them."""

    command: int
    lat: float = 0.0
    lon: float = 0.0
    alt: float = 0.0
    params: tuple[float, float, float, float] = (0.0, 0.0, 0.0, 0.0)
    frame: int = MAV.MAV_FRAME_GLOBAL_RELATIVE_ALT_INT

    @classmethod
    def takeoff(cls, alt: float) -> MissionItem:
        """Climb to `alt` over the current position."""
        return cls(MAV.MAV_CMD_NAV_TAKEOFF, alt=alt)

    @classmethod
    def waypoint(cls, lat: float, lon: float, alt: float, hold_s: float = 0.0) -> MissionItem:
        """Fly to a point and stay `hold_s` seconds."""
        return cls(MAV.MAV_CMD_NAV_WAYPOINT, lat, lon, alt, (hold_s, 0.0, 0.0, 0.0))

    @classmethod
    def land(cls, lat: float = 0.0, lon: float = 0.0) -> MissionItem:
        """Land (at a point, or where the vehicle is when lat and lon are 0)."""
        return cls(MAV.MAV_CMD_NAV_LAND, lat, lon)

    @classmethod
    def return_to_launch(cls) -> MissionItem:
        """Fly home and land."""
        return cls(MAV.MAV_CMD_NAV_RETURN_TO_LAUNCH)


class MissionUpload:
    """One upload of a mission to one vehicle; `run()` blocks until ACK or an error."""

    def __init__(self, robot: str, mav: Any, send: Callable[[Any], None],
                 replies: queue.Queue[Any], target: tuple[int, int],
                 down_reason: Callable[[], str | None], step_timeout: float, retries: int) -> None:
        self.robot = robot
        self.mav = mav
        self.send = send
        self.replies = replies
        self.target = target
        self.down_reason = down_reason  # None while the link is up
        self.step_timeout = step_timeout
        self.retries = retries

    def run(self, items: Sequence[MissionItem], home: tuple[float, float]) -> None:
        """Upload `items`; item 0 (home) is added in front, as ArduPilot expects."""
        while not self.replies.empty():
            self.replies.get_nowait()  # stale replies of an earlier transfer
        all_items = [MissionItem(MAV.MAV_CMD_NAV_WAYPOINT, home[0], home[1], 0.0,
                                 frame=MAV.MAV_FRAME_GLOBAL_INT), *items]
        last_sent = self.mav.mission_count_encode(*self.target, len(all_items),
                                                  MAV.MAV_MISSION_TYPE_MISSION)
        self.send(last_sent)
        misses = 0
        while True:
            reply = self._next_reply()
            if reply is None:
                misses += 1
                if misses > self.retries:
                    raise CommandTimeout(self.robot, "mission upload", self.step_timeout,
                                         misses)
                self.send(last_sent)
                continue
            misses = 0
            if reply.get_type() == "MISSION_ACK":
                if reply.type == MAV.MAV_MISSION_ACCEPTED:
                    return
                name = MAV.enums["MAV_MISSION_RESULT"][reply.type].name
                raise CommandRejected(self.robot, "mission upload", name)
            seq = reply.seq
            if not 0 <= seq < len(all_items):
                raise CommandRejected(self.robot, "mission upload",
                                      f"vehicle asked for item {seq} of {len(all_items)}")
            last_sent = self._encode(seq, all_items[seq], reply.get_type())
            self.send(last_sent)

    def _next_reply(self) -> Any | None:
        deadline = time.monotonic() + self.step_timeout
        while True:
            reason = self.down_reason()
            if reason is not None:
                raise LinkDown(self.robot, f"{reason} (during mission upload)")
            remaining = deadline - time.monotonic()
            if remaining <= 0:
                return None
            try:
                return self.replies.get(timeout=min(remaining, 0.2))
            except queue.Empty:
                continue

    def _encode(self, seq: int, item: MissionItem, request: str) -> Any:
        current, autocontinue = 0, 1
        if request == "MISSION_REQUEST":  # an old vehicle asking for float coordinates
            frame = {MAV.MAV_FRAME_GLOBAL_RELATIVE_ALT_INT: MAV.MAV_FRAME_GLOBAL_RELATIVE_ALT,
                     MAV.MAV_FRAME_GLOBAL_INT: MAV.MAV_FRAME_GLOBAL}.get(item.frame, item.frame)
            return self.mav.mission_item_encode(
                *self.target, seq, frame, item.command, current, autocontinue, *item.params,
                item.lat, item.lon, item.alt, MAV.MAV_MISSION_TYPE_MISSION)
        return self.mav.mission_item_int_encode(
            *self.target, seq, item.frame, item.command, current, autocontinue, *item.params,
            round(item.lat * 1e7), round(item.lon * 1e7), item.alt, MAV.MAV_MISSION_TYPE_MISSION)
