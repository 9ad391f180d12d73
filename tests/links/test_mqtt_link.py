"""The MQTT link against the simulated UGV in its own process, on Mosquitto and amqtt."""

from __future__ import annotations

import signal
import threading
from collections.abc import Iterator
from typing import Any

import pytest

from mrss.links.errors import CommandRejected, LinkDown, LinkError
from mrss.links.geo import distance_m, offset
from mrss.links.mqtt import MqttLink
from mrss.testing import BrokerInfo, free_port, wait_until

from .conftest import Spawn
from .test_mavlink_link import Recorder

BASE = (-35.3635, 149.1650)
FIELD = offset(*BASE, 40.0, 0.0)  # 40 m north of base


def start_ugv(spawn: Spawn, broker: BrokerInfo, robot_id: str) -> Any:
    return spawn("mrss", "sim", "ugv", "--broker", broker.url, "--id", robot_id,
                 "--speedup", "20", "--tank", "50", "--keepalive", "2", "--rate", "5",
                 f"--base={BASE[0]},{BASE[1]}")


@pytest.fixture(params=["mosquitto", "amqtt"])
def broker(request: pytest.FixtureRequest) -> BrokerInfo:
    info: BrokerInfo = request.getfixturevalue("mqtt_broker" if request.param == "mosquitto"
                                               else "amqtt")
    return info


@pytest.fixture()
def ugv(spawn: Spawn, broker: BrokerInfo, request: pytest.FixtureRequest
        ) -> Iterator[tuple[MqttLink, Recorder, Any, BrokerInfo]]:
    robot_id = f"ugv{abs(hash(request.node.name)) % 10000}"
    proc = start_ugv(spawn, broker, robot_id)
    rec = Recorder()
    link = MqttLink(robot_id, broker.url, telemetry_timeout=3.0,
                    on_link_state=rec.on_state, on_telemetry=rec.on_telemetry)
    link.start()
    try:
        link.wait_up(timeout=20)
        yield link, rec, proc, broker
    finally:
        link.close()


def tank(link: MqttLink) -> float:
    record = link.latest("tank")
    assert record is not None
    level: float = record["level"]
    return level


def test_ugv_drives_pumps_until_empty_and_refills_at_base(
        ugv: tuple[MqttLink, Recorder, Any, BrokerInfo]) -> None:
    link, rec, _, _ = ugv
    assert rec.states[-1] == (True, f"telemetry from {link.robot_id}")
    assert tank(link) == 50.0
    assert link.goto(*FIELD).status == "done"
    def near_field() -> bool:
        pos = link.latest("position")
        return pos is not None and distance_m(pos["lat"], pos["lon"], *FIELD) < 1.0

    wait_until(near_field, timeout=2, message="telemetry at the goto target")
    wait_until(lambda: (link.latest("status") or {}).get("at_base") is False, timeout=5,
               message="away from base")
    assert link.pump(True, litres=20, wait=True).reason == "delivered"
    wait_until(lambda: tank(link) == pytest.approx(30.0, abs=0.01), timeout=5, message="30 L")
    with pytest.raises(CommandRejected, match="failed: tank empty"):
        link.pump(True, litres=100, wait=True)
    wait_until(lambda: tank(link) == 0.0, timeout=5, message="empty tank")
    with pytest.raises(CommandRejected, match="rejected: tank empty"):
        link.pump(True)
    battery = link.latest("battery")
    assert battery is not None and battery["remaining"] < 100.0  # driving drains it
    assert link.return_to_base().status == "done"
    wait_until(lambda: tank(link) == 50.0, timeout=10, message="tank refilled at base")
    assert (link.latest("status") or {}).get("at_base") is True


def test_commands_are_refused_or_cancelled_with_reasons(
        ugv: tuple[MqttLink, Recorder, Any, BrokerInfo]) -> None:
    link, _, _, _ = ugv
    link.teleop(True)
    with pytest.raises(CommandRejected, match="teleop is on"):
        link.goto(*FIELD)
    link.drive(2.0, 90.0)
    wait_until(lambda: (link.latest("position") or {}).get("speed", 0) > 0, timeout=5,
               message="teleop driving")
    link.teleop(False)
    with pytest.raises(CommandRejected, match="teleop is off"):
        link.drive(1.0, 0.0)
    far = offset(*BASE, 5000.0, 0.0)
    outcome: list[BaseException] = []

    def skill() -> None:
        try:
            link.goto(*far, wait=True, timeout=30)
        except LinkError as exc:
            outcome.append(exc)

    worker = threading.Thread(target=skill)
    worker.start()
    wait_until(lambda: (link.latest("status") or {}).get("mode") == "goto", timeout=5,
               message="goto running")
    link.stop()
    worker.join(timeout=10)
    assert len(outcome) == 1 and isinstance(outcome[0], CommandRejected)
    assert "cancelled: stopped" in str(outcome[0])


def test_last_will_takes_link_down_fails_waiters_and_restart_brings_it_back(
        spawn: Spawn, ugv: tuple[MqttLink, Recorder, Any, BrokerInfo]) -> None:
    link, rec, proc, broker = ugv
    outcome: list[BaseException] = []

    def skill() -> None:
        try:
            link.goto(*offset(*BASE, 5000.0, 0.0), wait=True, timeout=60)
        except LinkError as exc:
            outcome.append(exc)

    worker = threading.Thread(target=skill)
    worker.start()
    wait_until(lambda: (link.latest("status") or {}).get("mode") == "goto", timeout=5,
               message="goto running")
    proc.kill()
    proc.wait()
    wait_until(lambda: not link.up, timeout=10, message="link down")
    worker.join(timeout=10)
    assert link.reason in ("last will: offline", "telemetry timeout: none for 3.0 s")
    wait_until(lambda: link.reason == "last will: offline", timeout=10, message="last will")
    assert len(outcome) == 1 and isinstance(outcome[0], LinkDown)
    with pytest.raises(LinkDown, match="last will: offline"):
        link.stop()
    start_ugv(spawn, broker, link.robot_id)
    link.wait_up(timeout=20)
    assert link.stop().status == "done"
    assert [up for up, _ in rec.states][-2:] == [False, True]


def test_frozen_robot_is_detected_by_telemetry_timeout(
        mqtt_broker: BrokerInfo, spawn: Spawn) -> None:
    proc = start_ugv(spawn, mqtt_broker, "frozen1")
    rec = Recorder()
    link = MqttLink("frozen1", mqtt_broker.url, telemetry_timeout=1.0,
                    on_link_state=rec.on_state)
    link.start()
    try:
        link.wait_up(timeout=20)
        proc.send_signal(signal.SIGSTOP)
        wait_until(lambda: not link.up, timeout=5, message="link down")
        assert rec.states[-1] == (False, "telemetry timeout: none for 1.0 s")
        proc.send_signal(signal.SIGCONT)
        link.wait_up(timeout=20)
    finally:
        link.close()
    assert rec.states[-1] == (False, "link closed")


def test_link_and_robot_reconnect_after_the_broker_restarts(spawn: Spawn) -> None:
    port = free_port()
    url = f"mqtt://127.0.0.1:{port}"

    def start_broker() -> Any:
        proc = spawn("mrss.actors.broker.service", "--host", "127.0.0.1", "--port", str(port))
        wait_until(lambda: _accepting(port), timeout=20, message="broker listening")
        return proc

    broker = start_broker()
    spawn("mrss", "sim", "ugv", "--broker", url, "--id", "rb1", "--speedup", "20")
    rec = Recorder()
    link = MqttLink("rb1", url, on_link_state=rec.on_state)
    link.start()
    try:
        link.wait_up(timeout=20)
        broker.kill()  # a broker crash; the amqtt broker may also hang on SIGTERM
        broker.wait(timeout=10)
        wait_until(lambda: not link.up, timeout=10, message="link down")
        assert link.reason.startswith("broker connection lost")
        start_broker()
        link.wait_up(timeout=30)  # both reconnect on their own, with backoff
        assert link.stop().status == "done"
    finally:
        link.close()
    assert [up for up, _ in rec.states][-4:] == [True, False, True, False]
    assert rec.states[-1] == (False, "link closed")


def _accepting(port: int) -> bool:
    import socket

    try:
        with socket.create_connection(("127.0.0.1", port), timeout=0.2):
            return True
    except OSError:
        return False
