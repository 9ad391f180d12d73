"""`mrss bench record`: a what-if replay (mrss/recording/whatif.py) of a 30-minute
wildfire mission through the unchanged agent: reading the file, and the agent's run.

The mission is written as the recorder writes a real one (McapRecordingWriter): an
operator area goal a minute (the UAV covers it in 40 s), a hotspot a minute (the UGV
supplies it in 30 s), both robots' telemetry at 5 Hz and eight components' heartbeats
at 1 Hz, each message at its time. Through the unchanged agent the decisions must be the
recorded ones.
"""

from __future__ import annotations

import time
from collections.abc import Iterator
from dataclasses import dataclass
from pathlib import Path

from mrss.agentspeak.parser import parse_literal
from mrss.agentspeak.terms import term_str
from mrss.errors import DecodeError
from mrss.messages import (
    ActionRequest,
    ActionState,
    ActionStatus,
    Envelope,
    Heartbeat,
    Message,
    Percept,
    RobotData,
    decode,
    encode,
)
from mrss.recording.files import recorded_messages
from mrss.recording.mcap_writer import McapRecordingWriter
from mrss.recording.whatif import what_if
from mrss.recording.whatif_timeline import timeline

WILDFIRE_AGENT = Path(__file__).resolve().parents[2] / "projects" / "wildfire" / "agent.asl"
START = 1_765_000_000.0


@dataclass(frozen=True)
class WhatIfRun:
    minutes: float
    messages: int
    inputs: int
    decisions: int
    read_s: float
    agent_s: float
    same: bool


def _events(minutes: int) -> Iterator[tuple[float, str, Message]]:
    for minute in range(minutes):
        base = minute * 60.0
        area, spot = f"a{minute}", f"hs{minute}"
        lat, lon = -35.36 - minute / 1000, 149.16 + minute / 1000
        cover, supply = f"c{minute:031x}", f"s{minute:031x}"
        supply_text = term_str(parse_literal(f"supply_water(ugv1,{spot},{lat},{lon},60)"))
        yield base + 1, "events", Percept(literal=f"area_goal_received({area}, 2)")
        yield base + 1.1, "reasoner", ActionRequest(
            uuid=cover, name="cover", args=["uav1", area], robot="uav1", goal=area,
            priority=2, literal=f"cover(uav1,{area})")
        yield base + 1.2, "rcl", ActionStatus(uuid=cover, state=ActionState.RUNNING,
                                              robot="uav1")
        yield base + 41, "rcl", ActionStatus(uuid=cover, state=ActionState.SUCCEEDED,
                                             robot="uav1")
        yield base + 20, "worldmodel", Percept(literal=f"hotspot_detected({spot}, {lat}, {lon})")
        yield base + 20.1, "reasoner", ActionRequest(
            uuid=supply, name="supply_water", args=["ugv1", spot, lat, lon, 60], robot="ugv1",
            goal=spot, priority=10, literal=supply_text)
        yield base + 50, "rcl", ActionStatus(uuid=supply, state=ActionState.SUCCEEDED,
                                             robot="ugv1")
    for tick in range(minutes * 60 * 5):
        t = tick / 5
        for robot in ("uav1", "ugv1"):
            yield t, "rcl", RobotData(robot=robot, data={
                "lat": -35.36 + tick / 1e6, "lon": 149.16, "alt": 30.0, "battery": 90.0})
        if tick % 5 == 0:
            for component in ("rcl", "reasoner", "events", "datalayer", "worldmodel",
                              "sim_uav", "sim_ugv", "broker"):
                yield t, component, Heartbeat(component=component, pid=100)


def write_mission(path: Path, minutes: int) -> int:
    """A recording of a `minutes`-long mission; the number of bus messages in it."""
    events = sorted(_events(minutes), key=lambda e: e[0])
    with path.open("wb") as handle:
        writer = McapRecordingWriter(handle, created=START)
        for at, src, body in events:
            writer.received(START + at, list(encode(body, src=src, inc=1)))
        writer.finish()
    return len(events)


def _envelopes(path: Path) -> Iterator[tuple[Envelope, float]]:
    with path.open("rb") as handle:
        for message in recorded_messages(handle):
            try:
                yield decode(*message.frames), message.t
            except DecodeError:
                continue


def run_what_if(path: Path, messages: int, minutes: float) -> WhatIfRun:
    """What if the mission in `path` had run the unchanged wildfire agent: timed."""
    start = time.perf_counter()
    line = timeline(_envelopes(path))
    read = time.perf_counter() - start
    result = what_if(WILDFIRE_AGENT, line)
    agent = time.perf_counter() - start - read
    return WhatIfRun(minutes, messages, len(line.inputs), len(result.recorded), read, agent,
                     result.first_difference is None)
