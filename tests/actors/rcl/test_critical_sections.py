"""A skill's critical section (`Skill.critical`) is never pre-empted, suspended or
cancelled from inside: those wait until it ends, then apply; a teleop (the operator's
emergency stop) still stops the robot inside it, and a section held past its bound
defers nothing any more. Real RCL core, MQTT link, Mosquitto and the UGV simulator as an
OS process (`mrss sim ugv`); a second robot is the in-process fake of rcl_sim.
"""

from __future__ import annotations

import subprocess
import sys
from collections.abc import Iterator
from pathlib import Path

import pytest

from mrss.actors.rcl.skill import CriticalSection
from mrss.api import ActionError, Resource, Skill, SkillOutcome, distance_m
from mrss.links.mqtt import MqttLink
from mrss.messages import ActionControl, ActionStatus
from mrss.sim.ugv import DEFAULT_BASE
from mrss.testing import BrokerInfo, wait_until
from tests.actors.rcl.rcl_sim import RclEnv, SimRobot, request_fields

NEAR = (DEFAULT_BASE[0] + 0.0003, DEFAULT_BASE[1])  # ~33 m north of the base
FAR = (DEFAULT_BASE[0] + 0.01, DEFAULT_BASE[1])  # ~1.1 km: never reached in a test


class Land(Skill):
    """Drives to a point inside a critical section ("landing"), records `landed`, then
    holds the resource until interrupted (so a deferred stop is seen to apply after)."""

    def __init__(self, target: tuple[float, float], bound: float) -> None:
        self.resources = (Resource("airspace"),)  # type: ignore[misc]
        self.target, self.bound = target, bound

    def run(self) -> bool:
        with self.critical("landing", bound=self.bound):
            self.link.goto(*self.target, wait=False)
            while not self._there():
                self.link.require_up()
                if self.wait(0.05):  # only an urgent stop (teleop, robot lost) in here
                    return False
            self.record_progress(landed=True)
        while not self.wait(0.05):
            pass
        return False

    def _there(self) -> bool:
        at = self.link.latest("position")
        return at is not None and distance_m(at["lat"], at["lon"], *self.target) <= 3.0

    def finish(self, outcome: SkillOutcome) -> None:
        if outcome is SkillOutcome.INTERRUPTED:
            self.link.stop()


@pytest.fixture
def ugv(mqtt_broker: BrokerInfo) -> Iterator[MqttLink]:
    proc = subprocess.Popen([sys.executable, "-m", "mrss", "sim", "ugv", "--broker",
                             mqtt_broker.url, "--id", "ugv1", "--speedup", "4", "--rate",
                             "10"], stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
    link = MqttLink("ugv1", mqtt_broker.url)
    link.start()
    try:
        wait_until(lambda: link.latest("position") is not None, timeout=20,
                   message="the simulated UGV's telemetry")
        yield link
    finally:
        link.close()
        proc.terminate()
        proc.wait(timeout=10)


def _start(tmp_path: Path, link: MqttLink, bound: float) -> tuple[RclEnv, SimRobot]:
    env = RclEnv(tmp_path / "journal.sqlite3", {})
    uav = SimRobot("uav1")
    env.layer.recipes["land"] = lambda a: [Land((float(a.args[2]), float(a.args[3])), bound)]
    env.start(robots={"ugv1": link, "uav1": uav})  # type: ignore[dict-item]
    return env, uav


def _in_section(env: RclEnv, uuid: str) -> bool:
    last = env.statuses.last(uuid)
    return last is not None and last.critical == "landing"


def _states_after(statuses: list[ActionStatus], pred: object) -> list[ActionStatus]:
    first = next(i for i, s in enumerate(statuses) if pred(s))  # type: ignore[operator]
    return statuses[first:]


def test_a_preemption_waits_for_the_critical_section_then_preempts(
        ugv: MqttLink, tmp_path: Path) -> None:
    env, uav = _start(tmp_path, ugv, bound=60.0)
    try:
        core = env.core
        core.submit_fields(request_fields("low", "land", "ugv1", "g1", *NEAR, priority=1))
        wait_until(lambda: _in_section(env, "low"), timeout=10, message="low in its section")
        core.submit_fields(request_fields("high", "hold", "uav1", "g2", "airspace", "y",
                                          priority=5))
        wait_until(lambda: (env.statuses.last("low") or _none()).deferring, timeout=10,
                   message="low's status: a stop waits for its section")
        deferred = env.statuses.last("low")
        assert deferred is not None and deferred.state == "running"
        assert deferred.critical == "landing" and deferred.critical_bound == 60.0
        assert "deferred until critical section 'landing'" in deferred.reason
        wait_until(env.statuses.reached("low", "suspended"), timeout=30,
                   message="low pre-empted once it has landed")
        wait_until(lambda: uav.is_moving_to("y"), message="high got the airspace")
        low = env.statuses.of("low")
        suspended = low[-1]
        assert suspended.progress.get("landed") is True  # the section ran to its end
        at = ugv.latest("position")
        assert at is not None and distance_m(at["lat"], at["lon"], *NEAR) <= 5.0
        ended = _states_after(low, lambda s: s.reason == "critical section 'landing' ended")
        assert [s.state for s in ended] == ["running", "suspended"], low
        assert all(s.state == "running" for s in low[1:-1])  # never suspended inside it
        assert core.broker.holders("airspace") == {"high"}
        uav.arrive()
        wait_until(env.statuses.reached("high", "succeeded"))
    finally:
        uav.halt()
        env.stop()


def test_an_operator_cancel_waits_only_until_the_sections_bound(
        ugv: MqttLink, tmp_path: Path) -> None:
    env, uav = _start(tmp_path, ugv, bound=1.5)
    try:
        env.core.submit_fields(request_fields("far", "land", "ugv1", "g1", *FAR))
        wait_until(lambda: _in_section(env, "far"), timeout=10, message="in its section")
        env.core.control(ActionControl("cancel", "far"))
        wait_until(lambda: (env.statuses.last("far") or _none()).deferring, timeout=10)
        wait_until(env.statuses.reached("far", "cancelled"), timeout=30,
                   message="cancelled once the section outlasted its bound")
        reasons = [s.reason for s in env.statuses.of("far")]
        assert "critical section 'landing' held past its bound 1.5s" in reasons
        assert "critical section 'landing' ended" not in reasons[:-1]  # it never ended
        assert not env.statuses.of("far")[-1].progress.get("landed")
    finally:
        uav.halt()
        env.stop()


def test_a_teleop_stops_the_robot_inside_the_critical_section(
        ugv: MqttLink, tmp_path: Path) -> None:
    env, uav = _start(tmp_path, ugv, bound=60.0)
    try:
        env.core.submit_fields(request_fields("far", "land", "ugv1", "g1", *FAR))
        wait_until(lambda: _in_section(env, "far"), timeout=10, message="in its section")
        env.core.availability.set_teleop("ugv1", True)
        wait_until(env.statuses.reached("far", "suspended"), timeout=10,
                   message="teleop suspends inside the section")
        assert not env.statuses.last("far").progress.get("landed")  # type: ignore[union-attr]
        wait_until(lambda: float((ugv.latest("position") or {}).get("speed", 1.0)) == 0.0,
                   timeout=10, message="the robot stopped")
    finally:
        uav.halt()
        env.stop()


def test_a_section_needs_a_name_and_a_positive_bound() -> None:
    with pytest.raises(ActionError, match="bound must be a number"):
        CriticalSection("landing", 0)
    with pytest.raises(ActionError, match="needs a name"):
        CriticalSection("", 3.0)


def _none() -> ActionStatus:
    return ActionStatus(uuid="-", state="pending")  # type: ignore[arg-type]
