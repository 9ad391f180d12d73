"""The MQTT links of a process share one connection per broker (mrss.links.mqtt_session).

Real Mosquitto brokers (a private one per test where the test kills it); the robots
are a paho client publishing each robot's retained status and telemetry, each robot at
its own latitude so that a message given to the wrong link shows.
"""

from __future__ import annotations

import subprocess
import threading
import time
from collections.abc import Sequence
from contextlib import AbstractContextManager
from pathlib import Path

import pytest

from mrss.links.mqtt import MqttLink
from mrss.links.mqtt_session import MqttSession
from mrss.links.mqtt_url import new_client, parse_broker_url
from mrss.links.ugv_protocol import ONLINE, UgvTelemetry, UgvTopics
from mrss.testing import BrokerInfo, find_mosquitto, free_port, wait_until
from tests.mosquitto import require_mosquitto

from .sample_scopes import ScopeRecorder
from .test_link_timers import mqtt_links
from .test_mavlink_link import Recorder


def _lat(index: int) -> float:
    return -35.36 - index * 0.001


class _Robots:
    """Retained "online" and telemetry at 10 Hz for each robot, at its own latitude;
    reconnects with the broker."""

    def __init__(self, url: str, ids: Sequence[str]) -> None:
        self.ids = list(ids)
        self.topics = {r: UgvTopics.for_robot(r) for r in ids}
        address = parse_broker_url(url)
        self.client = new_client(f"test-robots-{free_port()}", address)
        self.client.on_connect = self._online
        self.client.reconnect_delay_set(min_delay=1, max_delay=1)
        self.client.connect_async(address.host, address.port, keepalive=5)
        self.client.loop_start()
        self._stop = threading.Event()
        self._thread = threading.Thread(target=self._feed, daemon=True)
        self._thread.start()

    def _online(self, client: object, userdata: object, flags: object, reason: object,
                properties: object) -> None:
        for topics in self.topics.values():
            self.client.publish(topics.status, ONLINE, qos=1, retain=True)

    def _feed(self) -> None:
        while not self._stop.wait(0.1):  # the robots' telemetry rate, not a synchronisation
            for index, robot in enumerate(self.ids):
                sample = UgvTelemetry(robot, time.time(), _lat(index), 149.16, 0.0, 0.0,
                                      90.0, 10.0, 50.0, False, "idle", True, False)
                self.client.publish(self.topics[robot].telemetry, sample.to_json(), qos=0)

    def close(self) -> None:
        self._stop.set()
        self._thread.join(timeout=5)
        self.client.disconnect()  # first: a loop stopped first sits out its 1 s select
        self.client.loop_stop()


def _links(url: str, ids: Sequence[str]) -> AbstractContextManager[
        dict[str, tuple[MqttLink, Recorder]]]:
    return mqtt_links(url, ids, telemetry_timeout=2.0)


def _paho_threads() -> list[str]:
    return [t.name for t in threading.enumerate() if t.name.startswith("paho-mqtt-client-")]


def _at_own_latitude(link: MqttLink, index: int) -> bool:
    position = link.latest("position")
    return position is not None and position["lat"] == pytest.approx(_lat(index))


def test_links_to_one_broker_share_one_connection_and_each_hears_only_its_robot(
        mqtt_broker: BrokerInfo) -> None:
    ids = [f"sh{k}" for k in range(12)]
    robots = _Robots(mqtt_broker.url, ids)
    before = set(_paho_threads())
    try:
        with _links(mqtt_broker.url, ids) as links:
            ours = set(_paho_threads()) - before
            assert len(ours) == 1, ours  # 12 links, one connection and one network thread
            session = links[ids[0]][0]._session
            assert session is not None and session.members == 12
            assert all(link._session is session for link, _ in links.values())
            for index, robot in enumerate(ids):
                link = links[robot][0]
                wait_until(lambda link=link, index=index: _at_own_latitude(link, index),
                           timeout=10, message=f"{robot}'s own telemetry")
            # One link leaves: the others stay up and keep hearing their robots.
            gone, _ = links.pop(ids[0])
            gone.close()
            assert session.members == 11
            assert not gone.up
            stamp = {r: links[r][0].latest("position") for r in ids[1:]}
            wait_until(lambda: all(links[r][0].latest("position") is not stamp[r]
                                   for r in ids[1:]), timeout=10,
                       message="fresh telemetry for the links that stayed")
            assert all(links[r][0].up for r in ids[1:])
        wait_until(lambda: not (set(_paho_threads()) - before), timeout=10,
                   message="the session's thread ended with its last link")
    finally:
        robots.close()


def test_links_with_another_login_or_keepalive_get_their_own_session(
        mqtt_broker: BrokerInfo) -> None:
    a = MqttLink("own-a", mqtt_broker.url, keepalive=5)
    b = MqttLink("own-b", mqtt_broker.url, keepalive=7)
    c = MqttLink("own-c", mqtt_broker.url, keepalive=5, username="someone")
    d = MqttLink("own-d", mqtt_broker.url, keepalive=5)
    links = [a, b, c, d]
    for link in links:
        link.start()
    try:
        assert a._session is d._session
        assert len({id(link._session) for link in links}) == 3
    finally:
        for link in links:
            link.close()


class _Raising:
    """A session member whose callbacks fail (a link's bug)."""

    def __init__(self) -> None:
        self.calls = 0

    def session_topics(self) -> tuple[str, ...]:
        return (UgvTopics.for_robot("sh-bad0").telemetry,)

    def session_connected(self) -> None:
        self.calls += 1
        raise RuntimeError("boom")

    def session_down(self, reason: str) -> None:
        raise RuntimeError("boom")

    def session_message(self, topic: str, payload: bytes) -> None:
        self.calls += 1
        raise RuntimeError("boom")


def test_a_link_failing_in_a_callback_does_not_reach_the_others(
        mqtt_broker: BrokerInfo) -> None:
    ids = ["sh-bad0", "sh-bad1"]
    robots = _Robots(mqtt_broker.url, ids)
    try:
        with _links(mqtt_broker.url, ids[1:]) as links:
            link = links[ids[1]][0]
            bad = _Raising()
            session = MqttSession.attach(link.address, link.keepalive, bad)
            try:
                wait_until(lambda: bad.calls >= 3, timeout=10,
                           message="the failing member was called again and again")
                stamp = link.latest("position")
                wait_until(lambda: link.latest("position") is not stamp, timeout=10,
                           message="the good link still hears its robot")
                assert link.up and _at_own_latitude(link, 1)
            finally:
                session.detach(bad)
    finally:
        robots.close()


def _mosquitto(port: int, folder: Path) -> subprocess.Popen[bytes]:
    binary = require_mosquitto(find_mosquitto(), "the broker-kill test")
    conf = folder / "mosquitto.conf"
    conf.write_text(f"listener {port} 127.0.0.1\nallow_anonymous true\n"
                    "persistence false\nset_tcp_nodelay true\n")
    return subprocess.Popen([binary, "-c", str(conf)], stdout=subprocess.DEVNULL,
                            stderr=subprocess.DEVNULL)


def test_all_links_go_down_with_a_killed_broker_and_come_back_with_it(
        tmp_path: Path) -> None:
    port = free_port()
    url = f"mqtt://127.0.0.1:{port}"
    broker = _mosquitto(port, tmp_path)
    ids = [f"sk{k}" for k in range(6)]
    robots = None
    try:
        robots = _Robots(url, ids)
        with _links(url, ids) as links:
            broker.kill()
            broker.wait(timeout=10)
            for link, _ in links.values():
                wait_until(lambda link=link: not link.up, timeout=15, message="link down")
                assert link.reason.startswith("broker connection lost")
            broker = _mosquitto(port, tmp_path)
            for index, robot in enumerate(ids):
                link, rec = links[robot]
                link.wait_up(timeout=30)  # the session reconnects and subscribes again
                assert [up for up, _ in rec.states][-3:] == [True, False, True]
                wait_until(lambda link=link, index=index: _at_own_latitude(link, index),
                           timeout=10, message=f"{robot}'s own telemetry again")
    finally:
        if robots is not None:
            robots.close()
        broker.kill()
        broker.wait(timeout=10)


def test_the_records_of_one_sample_are_handed_on_inside_one_scope(
        mqtt_broker: BrokerInfo) -> None:
    """The RCL's publisher gathers what is published inside the scope into one bus
    message: the link must open one scope per telemetry sample, around all its records."""
    robots = _Robots(mqtt_broker.url, ["scope1"])
    rec = ScopeRecorder()
    link = MqttLink("scope1", mqtt_broker.url, telemetry_timeout=2.0,
                    on_telemetry=rec.on_record)
    link.set_sample_scope(rec.scope)
    link.start()
    try:
        link.wait_up(timeout=20)
        wait_until(lambda: len(rec.scopes) >= 3, timeout=10, message="three samples")
        assert rec.outside == []
        assert rec.scopes[0] == ["position", "battery", "tank", "status"]  # first: status
        assert all(s == ["position", "battery", "tank"] for s in rec.scopes[1:3])
    finally:
        link.close()
        robots.close()
