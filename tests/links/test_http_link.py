"""The HTTP link against the simulated HTTP robot, over real loopback sockets."""

from __future__ import annotations

import threading
from collections.abc import Iterator
from typing import Any

import pytest

from mrss.check.robots import link_problems
from mrss.errors import ConfigError
from mrss.links.errors import CommandRejected, LinkDown
from mrss.links.factory import create_link
from mrss.links.failsafe import FailsafeAction, LinkDownCause, link_down_cause
from mrss.links.geo import distance_m, offset
from mrss.links.http import HttpLink
from mrss.sim.http_robot import SimHttpRobot
from mrss.testing import wait_until

HOME = (48.2082, 16.3738)


@pytest.fixture()
def robot() -> Iterator[SimHttpRobot]:
    sim = SimHttpRobot("bot1", HOME, speed=40.0)
    sim.start()
    try:
        yield sim
    finally:
        sim.stop()


class Recorder:
    """Link state transitions and telemetry records, as a robot actor would get them."""

    def __init__(self) -> None:
        self.states: list[tuple[bool, str]] = []
        self.records: list[dict[str, Any]] = []
        self.lock = threading.Lock()

    def state(self, up: bool, reason: str) -> None:
        with self.lock:
            self.states.append((up, reason))

    def record(self, record: dict[str, Any]) -> None:
        with self.lock:
            self.records.append(record)

    def of(self, kind: str) -> list[dict[str, Any]]:
        with self.lock:
            return [r for r in self.records if r["type"] == kind]


@pytest.fixture()
def recorder() -> Recorder:
    return Recorder()


def started(robot: SimHttpRobot, recorder: Recorder, **options: Any) -> HttpLink:
    link = create_link("bot1", "http", {"url": robot.url, "poll": 0.05, **options},
                       on_link_state=recorder.state, on_telemetry=recorder.record)
    assert isinstance(link, HttpLink)
    link.start()
    return link


@pytest.fixture()
def link(robot: SimHttpRobot, recorder: Recorder) -> Iterator[HttpLink]:
    link = started(robot, recorder, timeout=1.0)
    try:
        link.wait_up(20)
        yield link
    finally:
        link.close()


def test_commands_reach_the_robot_and_are_acknowledged(link: HttpLink,
                                                       robot: SimHttpRobot) -> None:
    lat, lon = offset(*HOME, 60.0, 30.0)
    ack = link.goto(lat, lon, wait=True, tolerance_m=1.0, timeout=60)
    assert ack.status == "accepted"
    assert robot.commands[-1]["cmd"] == "goto" and robot.commands[-1]["lat"] == lat
    position = link.latest("position")
    assert position is not None and distance_m(position["lat"], position["lon"], lat, lon) <= 1
    assert link.stop().status == "done"
    assert [c["cmd"] for c in robot.commands] == ["goto", "stop"]


def test_a_refused_command_raises_command_rejected_with_the_robots_reason(
        link: HttpLink, robot: SimHttpRobot) -> None:
    with pytest.raises(CommandRejected, match=r"HTTP 400: .*unknown command 'fly'") as info:
        link.command("fly")
    assert info.value.command == "fly"
    with pytest.raises(CommandRejected, match=r"'lat' out of range"):
        link.command("goto", lat=100.0, lon=0.0)
    robot.fail_with(503)
    with pytest.raises(CommandRejected, match=r"HTTP 503"):
        link.command("stop")
    assert robot.commands == []  # nothing refused was done


def test_telemetry_is_forwarded_as_records_of_the_robot(link: HttpLink,
                                                        recorder: Recorder) -> None:
    lat, lon = offset(*HOME, 0.0, 200.0)
    link.goto(lat, lon, wait=False)
    moving = wait_until(lambda: [r for r in recorder.of("position") if r["speed"] > 0],
                        timeout=20, message="a moving position record")
    assert moving[0]["robot"] == "bot1" and distance_m(*HOME, moving[-1]["lat"],
                                                       moving[-1]["lon"]) > 0
    assert recorder.of("battery")[0]["remaining"] == 100.0
    assert {r["mode"] for r in recorder.of("status")} >= {"idle", "goto"}


@pytest.mark.parametrize("outage", ["stopped", "answers 500"])
def test_the_link_goes_down_after_its_timeout_and_up_when_the_robot_returns(
        link: HttpLink, robot: SimHttpRobot, recorder: Recorder, outage: str) -> None:
    if outage == "stopped":
        robot.stop()
    else:
        robot.fail_with(500)
    wait_until(lambda: not link.up, timeout=20, message="link down")
    assert link.reason.startswith(f"no telemetry from {robot.url} for 1.0 s: ")
    assert ("connection refused" if outage == "stopped" else "HTTP 500") in link.reason
    assert link_down_cause(link.reason) is LinkDownCause.UNREACHABLE
    with pytest.raises(LinkDown):
        link.command("stop")
    if outage == "stopped":
        robot.start()
    else:
        robot.fail_with(None)
    link.wait_up(20)
    assert recorder.states[-1] == (True, "telemetry from bot1")
    assert [up for up, _ in recorder.states][-3:] == [True, False, True]
    assert link.stop().status == "done"


def test_the_failsafe_heartbeat_reaches_the_robot_and_its_failsafe_is_reported(
        robot: SimHttpRobot, recorder: Recorder) -> None:
    controlled = threading.Event()
    controlled.set()
    link = started(robot, recorder, failsafe="hold", failsafe_timeout=2.0)
    link.watch_controller(controlled.is_set)
    try:
        link.wait_up(20)
        wait_until(lambda: robot.heartbeats > 0, timeout=20, message="a heartbeat")
        assert robot.failsafe is not None and robot.failsafe.action is FailsafeAction.HOLD
        assert robot.failsafe.timeout_s == 2.0
        link.goto(*offset(*HOME, 0.0, 5000.0), wait=False)
        controlled.clear()  # the robot actor is gone: no more heartbeats
        wait_until(lambda: link_down_cause(link.reason) is LinkDownCause.FAILSAFE,
                   timeout=30, message="the failsafe reported")
        assert "bot1 lost its controller and took its failsafe (now idle)" in link.reason
        assert recorder.of("failsafe")[0]["event"] == "triggered"
        controlled.set()
        link.wait_up(20)
        assert recorder.states[-1] == (True, "control regained after a failsafe")
        assert [r["event"] for r in recorder.of("failsafe")] == ["triggered", "regained"]
    finally:
        link.close()
    assert not link.up and link.reason == "link closed"


def test_a_robot_never_reached_is_down_with_the_reason(recorder: Recorder) -> None:
    sim = SimHttpRobot("bot1", HOME)
    sim.start()
    url = sim.url
    sim.stop()  # a port nobody listens on
    link = create_link("bot1", "http", {"url": url, "poll": 0.05},
                       on_link_state=recorder.state)
    link.start()
    try:
        wait_until(lambda: "connection refused" in link.reason, timeout=20,
                   message="the refusal as the reason")
        assert not link.up and link.reason == f"connecting to {url}: connection refused"
    finally:
        link.close()


@pytest.mark.parametrize("options, key, message", [
    ({}, "url", "needs 'url'"),
    ({"url": "ftp://robot:80"}, "url", "must start with http:// or https://"),
    ({"url": "http://robot:port"}, "url", "not a valid URL"),
    ({"url": "http://robot:80", "pol": 0.5}, "pol", "unknown http link option"),
    ({"url": "http://robot:80", "poll": "fast"}, "poll", "must be of type float"),
    ({"url": "http://robot:80", "timeout": 0}, "timeout", "must be a positive number of seconds"),
    ({"url": "http://robot:80", "failsafe": "hodl"}, "failsafe", "did you mean 'hold'"),
])
def test_bad_options_are_config_errors_naming_the_key(options: dict[str, Any], key: str,
                                                      message: str) -> None:
    with pytest.raises(ConfigError, match=message) as info:
        create_link("bot1", "http", options, source="project.toml")
    assert info.value.key == key and info.value.file == "project.toml"


def test_check_names_a_misspelt_http_option_with_a_suggestion() -> None:
    problems = dict(link_problems("http", {"link": "http", "url": "http://robot:8080",
                                           "pol": 0.5, "timout": 2.0}, set()))
    assert "did you mean 'poll'?" in problems["pol"]
    assert "did you mean 'timeout'?" in problems["timout"]
    assert "http://" in dict(link_problems("http", {"url": "mqtt://x"}, set()))["url"]
    assert link_problems("http", {"url": "https://robot.example/api/v1", "poll": 1,
                                  "failsafe": "rtl"}, set()) == []
