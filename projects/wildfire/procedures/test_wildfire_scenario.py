"""End-to-end procedure: `mrss supervise wildfire` as a real process, driven like an operator.

An operator area goal goes in over MQTT; the simulated UAV (MAVLink over UDP) covers the
area and its thermal camera finds the two hidden hotspots; the world model rule sends
the UGV (MQTT) to the one with no water nearby, where it pumps 60 l; SIGINT then stops
everything: exit code 0, no process left. Everything is checked from the outside: on
the bus (statuses, percepts) and through the world model's HTTP API.

The simulators run 20 times faster than real time (MRSS_SIM_SPEEDUP); about 20 s.
"""

from __future__ import annotations

import json
import os
import signal
import subprocess
import sys
import threading
import urllib.request
from collections.abc import Iterator
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import psutil
import pytest

from mrss.bus import Subscriber
from mrss.bus.component import endpoints_from_config
from mrss.links.geo import distance_m
from mrss.links.mqtt_url import new_client, parse_broker_url
from mrss.messages import ActionStatus, Envelope, Heartbeat, Percept
from mrss.testing import wait_until

PROJECT = Path(__file__).resolve().parent.parent
HOTSPOT_1 = (-35.360387, 149.165678)       # far from the pond: the UGV must go
AREA = {"goal": "a1", "priority": 2, "center": [-35.360567, 149.165237], "radius": 100}
SPEEDUP = "20"

pytestmark = pytest.mark.slow


@dataclass
class BusLog:
    """Everything of interest seen on the running system's bus."""

    percepts: list[str] = field(default_factory=list)
    statuses: list[ActionStatus] = field(default_factory=list)
    heartbeats: set[str] = field(default_factory=set)
    lock: threading.Lock = field(default_factory=threading.Lock)

    def on_message(self, env: Envelope) -> None:
        with self.lock:
            if isinstance(env.body, Percept) and env.body.op == "add":
                self.percepts.append(env.body.literal)
            elif isinstance(env.body, ActionStatus):
                self.statuses.append(env.body)
            elif isinstance(env.body, Heartbeat):
                self.heartbeats.add(env.body.component)

    def ended(self, robot: str, state: str) -> list[ActionStatus]:
        with self.lock:
            return [s for s in self.statuses if s.robot == robot and s.state == state]

    def percept(self, prefix: str) -> list[str]:
        with self.lock:
            return [p for p in self.percepts if p.startswith(prefix)]


@dataclass
class System:
    process: subprocess.Popen[bytes]
    run_dir: Path
    bus: BusLog
    output: Path

    def file(self, name: str) -> str:
        return (self.run_dir / name).read_text(encoding="utf-8").strip()

    def world(self, object_id: str) -> dict[str, Any] | None:
        try:
            with urllib.request.urlopen(f"{self.file('worldmodel.url')}/objects/{object_id}",
                                        timeout=5) as resp:
                result: dict[str, Any] = json.loads(resp.read())
                return result
        except urllib.error.HTTPError as exc:
            if exc.code == 404:
                return None
            raise

    def operator(self, topic: str, payload: dict[str, Any]) -> None:
        address = parse_broker_url(self.file("broker.url"))
        client = new_client("procedure-operator", address)
        client.connect(address.host, address.port)
        client.loop_start()
        try:
            info = client.publish(topic, json.dumps(payload), qos=1)
            info.wait_for_publish(5)
            assert info.is_published()
        finally:
            client.disconnect()
            client.loop_stop()

    def log(self) -> str:
        return self.output.read_text(encoding="utf-8", errors="replace")[-6000:]


@pytest.fixture()
def system(tmp_path: Path) -> Iterator[System]:
    run_dir = tmp_path / "run"
    output = tmp_path / "supervise.log"
    env = dict(os.environ, MRSS_PROJECTS=str(PROJECT.parent), MRSS_SIM_SPEEDUP=SPEEDUP)
    with output.open("wb") as sink:
        process = subprocess.Popen(
            [sys.executable, "-m", "mrss", "supervise", "wildfire", "--run-dir", str(run_dir)],
            stdout=sink, stderr=subprocess.STDOUT, env=env)
    sub: Subscriber | None = None
    try:
        wait_until(lambda: (run_dir / "bus-pub.sock").exists() or process.poll() is not None,
                   20, message="the bus proxy")
        bus = BusLog()
        sub = Subscriber(endpoints_from_config({}, run_dir),
                         prefixes=["percept", "action.status", "sup.heartbeat."])
        sub.start(bus.on_message)
        yield System(process, run_dir, bus, output)
    finally:
        if sub is not None:
            sub.close()
        if process.poll() is None:
            tree = psutil.Process(process.pid).children(recursive=True)
            process.kill()
            for child in tree:
                try:
                    child.kill()
                except psutil.NoSuchProcess:
                    pass
            process.wait(10)


def test_area_goal_to_water_on_the_hotspot(system: System) -> None:
    bus = system.bus
    wait_until(lambda: {"rcl", "reasoner"} <= bus.heartbeats or system.process.poll() is not None,
               30, message="the RCL and reasoner heartbeats")
    assert system.process.poll() is None, system.log()

    def robots_reporting() -> bool:   # telemetry reaches the world model: links are up
        uav, ugv = system.world("uav1"), system.world("ugv1")
        return bool(uav and uav.get("position") and ugv and ugv.get("position"))

    wait_until(robots_reporting, 20, message="telemetry of both robots in the world model")

    system.operator("mrss/ui/area", AREA)

    # the UAV covers the area; its thermal camera sees both hidden hotspots
    wait_until(lambda: bus.ended("uav1", "succeeded"), 40, message="the cover action to succeed")
    covered = bus.ended("uav1", "succeeded")[0]
    assert covered.progress.get("waypoint") == covered.progress.get("waypoints")
    hs1, hs2 = system.world("hs1"), system.world("hs2")
    assert hs1 is not None and hs2 is not None, system.log()
    assert distance_m(hs1["position"]["lat"], hs1["position"]["lon"], *HOTSPOT_1) < 1.0
    assert hs1["attributes"]["seen_by"] == "uav1"

    # only the hotspot with no water source within 150 m is sent to the UGV
    wait_until(lambda: bus.ended("ugv1", "succeeded"), 40, message="the supply action to succeed")
    assert bus.percept("hotspot_detected(hs1,")
    assert not bus.percept("hotspot_detected(hs2,")
    supplied = bus.ended("ugv1", "succeeded")[0]
    assert supplied.progress.get("pumped", 0) >= 59.5
    ugv = system.world("ugv1")
    assert ugv is not None
    assert distance_m(ugv["position"]["lat"], ugv["position"]["lon"], *HOTSPOT_1) < 5.0
    wait_until(lambda: (system.world("ugv1") or {}).get("attributes", {}).get("water", 200)
               <= 141, 10, message="the tank to show the 60 l pumped")
    assert not bus.ended("uav1", "failed") and not bus.ended("ugv1", "failed"), system.log()

    # Ctrl-C: everything stops, exit code 0, no process left behind
    tree = psutil.Process(system.process.pid).children(recursive=True)
    assert len(tree) >= 9
    system.process.send_signal(signal.SIGINT)
    assert system.process.wait(30) == 0, system.log()
    wait_until(lambda: not [p for p in tree if p.is_running() and p.status() != "zombie"],
               10, message="every component process to be gone")
