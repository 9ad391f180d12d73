"""The bus traffic `mrss bench record` records: a mission's mix of message kinds.

Telemetry dominates a real bus (robots at 5-10 Hz, each record also written as a
Foxglove LocationFix), then action statuses, percepts, heartbeats and log lines. The
numbers vary per message, so compression sees what a recording of a mission holds.
"""

from __future__ import annotations

import random

from mrss.messages import (
    ActionState,
    ActionStatus,
    Heartbeat,
    LogRecord,
    Message,
    Percept,
    RobotData,
    encode,
)

ROBOTS = 10


def mission_message(i: int, rng: random.Random) -> Message:
    """The `i`-th message of the mix: 6 in 10 telemetry, then statuses, percepts,
    heartbeats and log lines."""
    slot = i % 10
    robot = f"uav{i % ROBOTS}"
    if slot < 6:
        return RobotData(robot=robot, data={
            "lat": 48.2 + rng.random() / 100, "lon": 16.37 + rng.random() / 100,
            "alt": round(30 + rng.random() * 5, 2), "battery": round(rng.uniform(20, 100), 1),
            "heading": round(rng.uniform(0, 360), 1), "mode": "GUIDED"})
    if slot == 6:
        return ActionStatus(uuid=f"{i:032x}", state=ActionState.RUNNING, robot=robot,
                            name="cover", goal=f"area{i % 7}",
                            progress={"waypoint": i % 40, "of": 40})
    if slot == 7:
        return Percept(literal=f"hotspot_detected(h{i}, {48.2 + rng.random() / 100:.6f}, "
                               f"{16.37 + rng.random() / 100:.6f})")
    if slot == 8:
        return Heartbeat(component=f"c{i % 8}", pid=1000 + i % 8)
    return LogRecord(component="rcl", level="INFO",
                     message=f"action {i:x} on {robot}: waypoint {i % 40} reached")


def mission_frames(count: int, seed: int = 1) -> list[list[bytes]]:
    """`count` messages of the mix as bus frames (each `[topic, envelope]`)."""
    rng = random.Random(seed)
    return [list(encode(mission_message(i, rng), src="sim", inc=1)) for i in range(count)]
