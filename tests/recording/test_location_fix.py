"""Foxglove LocationFix channels carry the robot's own positions: a record of another
type that has a lat and lon (a hotspot the UAV saw) is not where the robot is."""

from __future__ import annotations

import json
import signal
from pathlib import Path

from mcap.reader import make_reader

from mrss.bus import Publisher
from mrss.messages import Percept, RobotData
from mrss.recording.schemas import LOCATION_FIX, location_fix
from mrss.testing import wait_until
from tests.commands.cli_bus import mrss_process, running_bus
from tests.recording.test_mcap_recording import mcap_percepts

POSITION = {"type": "position", "lat": -35.3632, "lon": 149.1652, "alt": 584.0}
HOTSPOT = {"type": "hotspot", "id": 1, "lat": -35.3604, "lon": 149.1657,
           "temperature": 450.0}
SAMPLE = {"lat": -35.3630, "lon": 149.1650}  # a plain sample: no type
BATTERY = {"type": "battery", "remaining": 80.0}


def test_only_position_records_make_a_location_fix() -> None:
    assert location_fix("uav1", 1.5, POSITION) is not None
    assert location_fix("uav1", 1.5, SAMPLE) is not None
    assert location_fix("uav1", 1.5, HOTSPOT) is None
    assert location_fix("uav1", 1.5, {**POSITION, "type": "supply"}) is None
    assert location_fix("uav1", 1.5, BATTERY) is None


def test_a_recorded_hotspot_report_is_not_a_robot_position(tmp_path: Path) -> None:
    out = tmp_path / "fixes.mcap"
    with running_bus() as live, mrss_process("record", "--run-dir", str(live.run_dir),
                                             "--out", str(out)) as rec:
        rec.wait_line("recording ")
        with Publisher(live.endpoints, src="rcl") as pub:
            counter = iter(range(1, 100_000))
            wait_until(lambda: pub.publish(Percept(literal=f"sync({next(counter)})"))
                       and mcap_percepts(out), 30, interval=0.1, message="recording")
            for data in (POSITION, HOTSPOT, BATTERY, SAMPLE):
                pub.publish(RobotData(robot="uav1", data=data))
            pub.publish(Percept(literal="done"))
            wait_until(lambda: "done" in mcap_percepts(out), 30, interval=0.1,
                       message="the records' chunk written")
        rec.proc.send_signal(signal.SIGINT)
        assert rec.finish() == 0, rec.stderr()

    with out.open("rb") as handle:
        fixes = [(json.loads(m.data)["latitude"], json.loads(m.data)["longitude"])
                 for schema, channel, m in make_reader(handle).iter_messages()
                 if schema is not None and schema.name == LOCATION_FIX
                 and channel.topic == "robot.uav1.location"]
    assert fixes == [(POSITION["lat"], POSITION["lon"]), (SAMPLE["lat"], SAMPLE["lon"])]


def test_in_the_wildfire_recording_the_uavs_fixes_are_its_positions_not_the_hotspot(
        wildfire_recording: Path) -> None:
    positions, hotspots, fixes = [], [], []
    with wildfire_recording.open("rb") as handle:
        for schema, channel, message in make_reader(handle).iter_messages():
            value = json.loads(message.data)
            if channel.topic == "robot.uav1.data":
                data = value["body"]["data"]
                if data.get("type") == "hotspot":
                    hotspots.append((data["lat"], data["lon"]))
                elif data.get("type") in (None, "position") and "lat" in data:
                    positions.append((message.publish_time, data["lat"], data["lon"]))
            elif channel.topic == "robot.uav1.location":
                assert schema is not None and schema.name == LOCATION_FIX
                fixes.append((message.publish_time, value["latitude"], value["longitude"]))
    assert hotspots, "the UAV reported the hotspot"
    assert fixes == positions and len(fixes) > 10
