"""The UGV's controller-heartbeat failsafe, end to end: simulator, link and observer are
separate MQTT clients on a private Mosquitto; the link runs in its own process, which
is stopped or killed. The robot's telemetry is read from the broker like any dashboard.
"""

from __future__ import annotations

import json
import signal
import threading
from collections.abc import Iterator
from pathlib import Path
from typing import Any

import pytest

from mrss.links.geo import distance_m, offset
from mrss.links.mqtt_url import new_client, parse_broker_url
from mrss.links.ugv_protocol import UgvTelemetry, UgvTopics, parse_telemetry
from mrss.testing import BrokerInfo, wait_until

from .conftest import Spawn
from .failsafe_driver import LinkProcess

BASE = (-35.3635, 149.1650)
FAR = offset(*BASE, 3000.0, 0.0)     # never reached during a test
OTHER = offset(*BASE, 0.0, -3000.0)
TIMEOUT_S = 4.0
WAIT = 60.0


class Observer:
    """Subscribes to a robot's telemetry, as a dashboard would."""

    def __init__(self, broker: BrokerInfo, robot: str) -> None:
        self.topics = UgvTopics.for_robot(robot)
        self.robot = robot
        self.samples: list[UgvTelemetry] = []
        self._lock = threading.Lock()
        self.client = new_client(f"observer-{robot}", parse_broker_url(broker.url))
        self.client.on_connect = lambda c, *_: c.subscribe(self.topics.telemetry, qos=0)
        self.client.on_message = self._on_message
        self.client.connect(broker.host, broker.port)
        self.client.loop_start()

    def _on_message(self, client: Any, userdata: Any, message: Any) -> None:
        sample = parse_telemetry(bytes(message.payload), self.robot)
        with self._lock:
            self.samples.append(sample)

    def latest(self) -> UgvTelemetry | None:
        with self._lock:
            return self.samples[-1] if self.samples else None

    def holds(self, check: Any) -> bool:
        sample = self.latest()
        return sample is not None and bool(check(sample))

    def close(self) -> None:
        self.client.disconnect()
        self.client.loop_stop()


@pytest.fixture()
def field(mqtt_broker: BrokerInfo, spawn: Spawn, tmp_path: Path,
          request: pytest.FixtureRequest) -> Iterator[tuple[str, Observer, list[LinkProcess]]]:
    robot = f"ugv{abs(hash(request.node.name)) % 10000}"
    own = getattr(request, "param", [])
    spawn("mrss", "sim", "ugv", "--broker", mqtt_broker.url, "--id", robot, "--speedup", "5",
          "--rate", "5", f"--base={BASE[0]},{BASE[1]}", *own)
    observer = Observer(mqtt_broker, robot)
    links: list[LinkProcess] = []
    try:
        yield robot, observer, links
    finally:
        for link in links:
            link.close()
        observer.close()


def start_link(links: list[LinkProcess], tmp_path: Path, broker: BrokerInfo, robot: str,
               **failsafe: Any) -> LinkProcess:
    link = LinkProcess(tmp_path / f"link-{len(links)}.log", "mqtt", robot,
                       {"broker_url": broker.url, "keepalive": 5, **failsafe})
    links.append(link)
    link.call("wait_up", 30)
    return link


def failsafe_reported_then_up(link: LinkProcess) -> tuple[str, str]:
    def pair() -> tuple[str, str] | None:
        states = link.states()
        for i, (up, why) in enumerate(states):
            if not up and why.startswith("failsafe: "):
                ups = [w for u, w in states[i + 1:] if u]
                if ups:
                    return why, ups[0]
        return None
    found: tuple[str, str] = wait_until(pair, timeout=WAIT,
                                        message="failsafe reported, then link up")
    return found


def away_from_base(t: UgvTelemetry) -> bool:
    return distance_m(t.lat, t.lon, *BASE) > 5.0


def test_sigstopped_link_ugv_returns_to_base_then_obeys_a_new_command(
        field: tuple[str, Observer, list[LinkProcess]], mqtt_broker: BrokerInfo,
        tmp_path: Path) -> None:
    robot, seen, links = field
    link = start_link(links, tmp_path, mqtt_broker, robot, failsafe="rtl",
                      failsafe_timeout=TIMEOUT_S)   # the robot has none: the link asks
    link.call("goto", *FAR, wait=False)
    wait_until(lambda: seen.holds(lambda t: t.mode == "goto" and away_from_base(t)
                                  and t.controller and not t.failsafe),
               timeout=WAIT, message="driving away, controlled")

    link.signal(signal.SIGSTOP)
    wait_until(lambda: seen.holds(lambda t: t.failsafe and not t.controller
                                  and t.mode == "return"), timeout=WAIT,
               message="failsafe: returning to base")

    link.signal(signal.SIGCONT)
    down, up = failsafe_reported_then_up(link)
    assert down.startswith(f"failsafe: {robot} lost its controller")
    assert up == "control regained after a failsafe"
    wait_until(lambda: seen.holds(lambda t: t.controller), timeout=WAIT,
               message="the robot hears its controller again")
    sample = seen.latest()
    assert sample is not None and sample.failsafe  # until commanded, as ArduPilot
    assert [r["event"] for r in link.telemetry("failsafe")] == ["triggered", "regained"]

    link.call("goto", *OTHER, wait=False)  # a new command takes effect
    wait_until(lambda: seen.holds(lambda t: t.mode == "goto" and not t.failsafe),
               timeout=WAIT, message="driving again, failsafe over")
    wait_until(lambda: link.telemetry("status")[-1]["failsafe"] is False, timeout=WAIT,
               message="the link's status record says the failsafe is over")


@pytest.mark.parametrize("field", [["--failsafe", "stop", "--failsafe-timeout", "4"]],
                         indirect=True)
def test_sigkilled_link_ugv_stops_and_a_new_link_reports_the_failsafe(
        field: tuple[str, Observer, list[LinkProcess]], mqtt_broker: BrokerInfo,
        tmp_path: Path) -> None:
    robot, seen, links = field
    link = start_link(links, tmp_path, mqtt_broker, robot)  # the robot's own failsafe
    link.call("pump", True)
    link.call("goto", *FAR, wait=False)
    wait_until(lambda: seen.holds(lambda t: t.mode == "goto" and t.pumping and t.controller
                                  and away_from_base(t)), timeout=WAIT,
               message="driving and pumping, controlled")

    link.signal(signal.SIGKILL)
    wait_until(lambda: seen.holds(lambda t: t.failsafe and t.mode == "idle"
                                  and t.speed == 0.0 and not t.pumping),
               timeout=WAIT, message="failsafe: stopped")

    second = start_link(links, tmp_path, mqtt_broker, robot)  # a new incarnation
    down, up = failsafe_reported_then_up(second)
    assert down.startswith(f"failsafe: {robot} lost its controller")
    assert "now idle" in down
    second.call("goto", *OTHER, wait=False)
    wait_until(lambda: seen.holds(lambda t: t.mode == "goto" and not t.failsafe),
               timeout=WAIT, message="driving again")


def test_heartbeat_carries_the_declared_failsafe(
        field: tuple[str, Observer, list[LinkProcess]], mqtt_broker: BrokerInfo,
        tmp_path: Path) -> None:
    robot, _, links = field
    beats: list[dict[str, Any]] = []
    topic = UgvTopics.for_robot(robot).heartbeat
    client = new_client(f"beat-observer-{robot}", parse_broker_url(mqtt_broker.url))
    client.on_connect = lambda c, *_: c.subscribe(topic, qos=0)
    client.on_message = lambda c, u, m: beats.append(json.loads(m.payload))
    client.connect(mqtt_broker.host, mqtt_broker.port)
    client.loop_start()
    try:
        start_link(links, tmp_path, mqtt_broker, robot, failsafe="hold", failsafe_timeout=7)
        wait_until(lambda: len(beats) >= 2, timeout=WAIT, message="two heartbeats")
        assert beats[-1]["failsafe"] == "hold" and beats[-1]["timeout"] == 7.0
        assert beats[-1]["ts"] > beats[-2]["ts"]
    finally:
        client.disconnect()
        client.loop_stop()
