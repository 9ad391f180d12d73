"""The shared link loop (mrss.links.timers): its jobs, and the MQTT and MAVLink links on it."""

from __future__ import annotations

import threading
import time
from collections.abc import Iterator, Sequence
from contextlib import contextmanager

from mrss.links.mavconn import MAV, MavConnection
from mrss.links.mavlink import MavlinkLink
from mrss.links.mqtt import MqttLink
from mrss.links.mqtt_url import new_client, parse_broker_url
from mrss.links.timers import THREAD_NAME, Timers
from mrss.links.ugv_protocol import ONLINE, UgvTelemetry, UgvTopics
from mrss.testing import BrokerInfo, free_port, wait_until

from .test_mavlink_link import Recorder


def _timer_threads() -> list[threading.Thread]:
    return [t for t in threading.enumerate() if t.name == THREAD_NAME]


def test_jobs_repeat_at_their_own_delays_on_one_thread_that_ends_with_the_last_job(
) -> None:
    timers = Timers(name="test-timers")
    runs: dict[str, list[str]] = {"a": [], "b": []}

    def job(key: str, again: float | None) -> float | None:
        runs[key].append(threading.current_thread().name)
        return again

    a = timers.schedule(lambda: job("a", 0.01), name="a")
    timers.schedule(lambda: job("b", None), delay=0.02, name="b")  # runs once
    wait_until(lambda: len(runs["a"]) >= 5 and runs["b"], timeout=5, message="both ran")
    assert set(runs["a"]) | set(runs["b"]) == {"test-timers"}
    assert len(runs["b"]) == 1  # None: done
    assert timers.running
    a.cancel()
    wait_until(lambda: not timers.running, timeout=5, message="the thread ended")
    done = len(runs["a"])
    timers.schedule(lambda: job("b", None), name="b again")  # a new thread on demand
    wait_until(lambda: len(runs["b"]) == 2, timeout=5, message="ran after a restart")
    assert len(runs["a"]) == done  # a cancelled job never runs again


def test_a_failing_job_is_retried_and_the_others_keep_running() -> None:
    timers = Timers(name="test-timers-fail")
    calls = {"bad": 0, "good": 0}

    def bad() -> float:
        calls["bad"] += 1
        raise RuntimeError("boom")

    def good() -> float:
        calls["good"] += 1
        return 0.01

    handles = [timers.schedule(bad, name="bad"), timers.schedule(good, name="good")]
    try:
        wait_until(lambda: calls["bad"] >= 2, timeout=5, message="the bad job retried")
        assert calls["good"] > calls["bad"]
    finally:
        for handle in handles:
            handle.cancel()


class _Robots:
    """MQTT robots as far as a link sees them: retained "online", telemetry at 10 Hz
    while `alive`."""

    def __init__(self, broker: BrokerInfo, ids: list[str]) -> None:
        self.alive = set(ids)
        self.topics = {r: UgvTopics.for_robot(r) for r in ids}
        self.client = new_client("test-robots", parse_broker_url(broker.url))
        self.client.connect(broker.host, broker.port)
        self.client.loop_start()
        for topics in self.topics.values():
            self.client.publish(topics.status, ONLINE, qos=1, retain=True)
        self._stop = threading.Event()
        self._thread = threading.Thread(target=self._feed, daemon=True)
        self._thread.start()

    def _feed(self) -> None:
        while not self._stop.wait(0.1):  # the robots' telemetry rate, not a synchronisation
            for robot in list(self.alive):
                sample = UgvTelemetry(robot, time.time(), -35.36, 149.16, 0.0, 0.0, 90.0,
                                      10.0, 50.0, False, "idle", True, False)
                self.client.publish(self.topics[robot].telemetry, sample.to_json(), qos=0)

    def close(self) -> None:
        self._stop.set()
        self._thread.join(timeout=5)
        self.client.disconnect()  # first: a loop stopped first sits out its 1 s select
        self.client.loop_stop()


@contextmanager
def mqtt_links(url: str, ids: Sequence[str], telemetry_timeout: float = 1.0
               ) -> Iterator[dict[str, tuple[MqttLink, Recorder]]]:
    """An MQTT link per robot of `ids` to the broker at `url`, each up; closed after."""
    links: dict[str, tuple[MqttLink, Recorder]] = {}
    try:
        for robot in ids:
            rec = Recorder()
            link = MqttLink(robot, url, telemetry_timeout=telemetry_timeout, keepalive=5,
                            on_link_state=rec.on_state)
            links[robot] = (link, rec)
            link.start()
        for link, _ in links.values():
            link.wait_up(timeout=20)
        yield links
    finally:
        for link, _ in links.values():
            link.close()


def _own_threads() -> set[str]:
    """Thread names but paho's network loops (one per MQTT client by design) and the
    foreign threads Python only knows as `Dummy-N` (they come and go with other work in
    the process, e.g. an earlier test's library threads)."""
    return {t.name for t in threading.enumerate()
            if not t.name.startswith("paho-mqtt-client-")
            and not isinstance(t, threading._DummyThread)}


def test_many_mqtt_links_share_one_watchdog_thread(mqtt_broker: BrokerInfo) -> None:
    few = [f"tw{k}" for k in range(2)]
    many = [f"tm{k}" for k in range(12)]
    robots = _Robots(mqtt_broker, few + many)
    try:
        with mqtt_links(mqtt_broker.url, few):
            with_few = _own_threads()
            assert len(_timer_threads()) == 1
            with mqtt_links(mqtt_broker.url, many):
                more = _own_threads() - with_few
                # 12 more links: no thread of theirs (a thread per link would be 12)
                assert not [n for n in more if any(r in n for r in many)], more
                assert len(more) < 3, more
                assert len(_timer_threads()) == 1
    finally:
        robots.close()


def test_a_link_whose_telemetry_stops_goes_down_and_comes_back_up(
        mqtt_broker: BrokerInfo) -> None:
    ids = [f"ts{k}" for k in range(4)]
    robots = _Robots(mqtt_broker, ids)
    try:
        with mqtt_links(mqtt_broker.url, ids) as links:
            quiet, (link, rec) = ids[0], links[ids[0]]
            robots.alive.discard(quiet)
            wait_until(lambda: not link.up, timeout=10, message=f"{quiet} down")
            assert rec.states[-1] == (False, "telemetry timeout: none for 1.0 s")
            assert all(links[r][0].up for r in ids[1:])  # the others are not affected
            robots.alive.add(quiet)
            link.wait_up(timeout=10)
            assert rec.states[-1] == (True, f"telemetry from {quiet}")
            assert [up for up, _ in rec.states][-3:] == [True, False, True]
    finally:
        robots.close()


class _Vehicles:
    """MAVLink vehicles as far as a link sees them: a heartbeat every 0.1 s while
    `alive`, from system 1 of each link's own UDP port."""

    def __init__(self, ports: dict[str, int]) -> None:
        self.alive = set(ports)
        self.conns = {r: MavConnection(f"udpout:127.0.0.1:{port}", source_system=1,
                                       source_component=1) for r, port in ports.items()}
        self._stop = threading.Event()
        self._thread = threading.Thread(target=self._beat, daemon=True)
        self._thread.start()

    def _beat(self) -> None:
        while not self._stop.wait(0.1):  # the vehicles' rate, not a synchronisation
            for robot in list(self.alive):
                conn = self.conns[robot]
                conn.send(conn.conn.mav.heartbeat_encode(
                    MAV.MAV_TYPE_QUADROTOR, MAV.MAV_AUTOPILOT_ARDUPILOTMEGA, 0, 4,
                    MAV.MAV_STATE_ACTIVE))

    def close(self) -> None:
        self._stop.set()
        self._thread.join(timeout=5)
        for conn in self.conns.values():
            conn.close()


@contextmanager
def _mavlinks(ports: dict[str, int]) -> Iterator[dict[str, tuple[MavlinkLink, Recorder]]]:
    links: dict[str, tuple[MavlinkLink, Recorder]] = {}
    try:
        for robot, port in ports.items():
            rec = Recorder()
            link = MavlinkLink(robot, f"udpin:127.0.0.1:{port}", heartbeat_timeout=1.0,
                               on_link_state=rec.on_state)
            links[robot] = (link, rec)
            link.start()
        for link, _ in links.values():
            link.wait_up(timeout=20)
        yield links
    finally:
        for link, _ in links.values():
            link.close()


def test_mavlink_udp_links_are_read_by_the_shared_loop_and_see_a_silent_vehicle(
) -> None:
    ports = {f"mv{k}": free_port() for k in range(10)}
    few = dict(list(ports.items())[:2])
    vehicles = _Vehicles(ports)
    try:
        with _mavlinks(few):
            with_few = {t.name for t in threading.enumerate()}
            with _mavlinks({r: p for r, p in ports.items() if r not in few}) as links:
                assert {t.name for t in threading.enumerate()} == with_few  # 8 more links
                assert len(_timer_threads()) == 1
                quiet, (link, rec) = "mv5", links["mv5"]
                vehicles.alive.discard(quiet)
                wait_until(lambda: not link.up, timeout=10, message=f"{quiet} down")
                assert rec.states[-1] == (False, "no heartbeat for 1.0 s")
                assert all(other.up for r, (other, _) in links.items() if r != quiet)
                vehicles.alive.add(quiet)
                link.wait_up(timeout=10)
                assert rec.states[-1] == (True, "heartbeat resumed from system 1")
    finally:
        vehicles.close()
