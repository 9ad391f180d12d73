"""The simulators' failsafe rules: controller timing, the copter's GCS failsafe decisions,
the ground robot's safe states, and their configuration."""

from __future__ import annotations

from pathlib import Path
from typing import Any

import pytest

from mrss.errors import ConfigError
from mrss.links.failsafe import FailsafeAction, FailsafePolicy
from mrss.links.geo import offset
from mrss.links.ugv_protocol import UgvAck, UgvCommand
from mrss.runtime.component import ComponentContext
from mrss.sim.component import SimUavComponent, SimUgvComponent
from mrss.sim.controller_watch import ControllerWatch, WatchEvent
from mrss.sim.copter import BRAKE, GUIDED, LAND, RTL, CopterModel
from mrss.sim.gcs_failsafe import GcsFailsafe
from mrss.sim.ugv_model import UgvModel

from .test_copter import HOME, airborne, fly

BASE = (-35.3635, 149.1650)


def test_watch_is_inactive_until_heard_then_loses_and_regains_once() -> None:
    w = ControllerWatch(5.0)
    assert w.poll(100.0) is None  # never heard: never lost
    w.heard(100.0)
    assert w.poll(105.0) is None and w.present(105.0)
    assert w.poll(105.1) is WatchEvent.LOST and w.poll(200.0) is None
    assert not w.present(200.0)
    w.heard(201.0)
    assert w.poll(201.0) is WatchEvent.REGAINED and w.poll(202.0) is None


def texts(m: CopterModel) -> list[str]:
    said = [t for _, t in m.texts]
    m.texts.clear()
    return said


@pytest.mark.parametrize(("action", "mode"), [(FailsafeAction.HOLD, BRAKE),
                                              (FailsafeAction.RTL, RTL),
                                              (FailsafeAction.STOP, LAND)])
def test_copter_in_flight_takes_the_declared_mode_and_keeps_it_when_the_gcs_is_back(
        action: FailsafeAction, mode: int) -> None:
    m = airborne()
    m.goto(*offset(*HOME, 500.0, 0.0), 10.0)
    fs = GcsFailsafe(m, FailsafePolicy(action, 3.0))
    fs.heard(255, 0.0)
    fs.check(3.0)
    assert m.mode == GUIDED and not fs.active
    texts(m)
    fs.check(3.5)
    assert m.mode == mode and fs.active and fs.fired == 1
    assert texts(m)[0] == "GCS Failsafe"
    fs.heard(255, 10.0)
    fs.check(10.0)
    assert not fs.active and m.mode == mode and texts(m) == ["GCS Failsafe Cleared"]


def test_copter_failsafe_disarms_on_the_ground_warns_when_disarmed_and_ignores_others() -> None:
    m = CopterModel(*HOME, 584.0)
    fs = GcsFailsafe(m, FailsafePolicy(FailsafeAction.RTL, 2.0))
    fs.heard(254, 0.0)                     # not SYSID_MYGCS: not our GCS
    fs.check(100.0)
    assert not fs.active
    fs.heard(255, 100.0)
    fs.check(103.0)
    assert fs.active and texts(m) == ["GCS Failsafe"] and not m.armed
    m = CopterModel(*HOME, 584.0)
    m.set_mode(GUIDED)
    m.arm()
    texts(m)
    fs = GcsFailsafe(m, FailsafePolicy(FailsafeAction.HOLD, 2.0))
    fs.heard(255, 0.0)
    fs.check(3.0)
    assert not m.armed and texts(m)[0] == "GCS Failsafe - Disarming"


def test_copter_failsafe_parameters_follow_arducopter() -> None:
    m = airborne()
    fs = GcsFailsafe(m)  # no policy: FS_GCS_ENABLE 0, nothing happens
    fs.heard(255, 0.0)
    fs.check(60.0)
    assert fs.enable == 0 and not fs.active and m.mode == GUIDED
    with pytest.raises(ValueError):
        fs.set_enable(2)  # "continue in auto": removed in ArduCopter 4
    with pytest.raises(ValueError):
        fs.set_timeout(0)
    fs.set_enable(5)
    fs.set_timeout(2.0)
    fs.heard(255, 60.0)
    fs.check(62.5)
    assert m.mode == LAND and fs.active
    fly(m, 60)
    assert m.landed and not m.armed


def model_driving() -> UgvModel:
    m = UgvModel("u", *BASE)
    far = offset(*BASE, 500.0, 0.0)
    m.apply(UgvCommand("goto", "g1", lat=far[0], lon=far[1]))
    m.apply(UgvCommand("pump", "p1", on=True))
    for _ in range(50):
        m.step(0.1)
    m.take_answers()
    return m


def test_ugv_stop_ends_motion_and_pump_until_commanded() -> None:
    m = model_driving()
    m.lose_controller(FailsafeAction.STOP, "no controller heartbeat for 5 s")
    assert m.take_answers() == [UgvAck("p1", "cancelled", "failsafe: no controller heartbeat "
                                       "for 5 s"),
                                UgvAck("g1", "cancelled", "failsafe: no controller heartbeat "
                                       "for 5 s")]
    m.step(1.0)
    t = m.telemetry()
    assert t.failsafe and t.mode == "idle" and t.speed == 0.0 and not t.pumping
    m.apply(UgvCommand("stop", "s1"))
    assert not m.telemetry().failsafe


def test_ugv_hold_keeps_pumping_and_rtl_drives_home() -> None:
    m = model_driving()
    m.lose_controller(FailsafeAction.HOLD, "gone")
    m.step(1.0)
    assert m.pumping and m.speed == 0.0 and m.mode == "idle" and m.failsafe
    m = model_driving()
    m.lose_controller(FailsafeAction.RTL, "gone")
    for _ in range(200):
        m.step(0.5)
    assert m.at_base and m.mode == "idle" and not m.pumping and m.failsafe


def test_ugv_in_teleop_only_stops_whatever_the_failsafe() -> None:
    m = UgvModel("u", *BASE)
    m.apply(UgvCommand("teleop", "t1", on=True))
    m.apply(UgvCommand("drive", "d1", speed=2.0, heading=90.0))
    m.lose_controller(FailsafeAction.RTL, "gone")
    m.step(1.0)
    assert m.speed == 0.0 and m.mode == "teleop" and m.target is None


def context(tmp_path: Path, name: str, **options: Any) -> ComponentContext:
    run_dir = tmp_path / "run"
    run_dir.mkdir(exist_ok=True)
    return ComponentContext(name=name, incarnation=1, project_dir=tmp_path, run_dir=run_dir,
                            options=dict(options))


@pytest.mark.parametrize(("options", "key", "text"), [
    ({"failsafe": "rlt"}, "failsafe", "did you mean 'rtl'?"),
    ({"failsafe": 1}, "failsafe", "must be one of hold, rtl, stop"),
    ({"failsafe": "hold", "failsafe_timeout": 500}, "failsafe_timeout", "between 2 and 120"),
    ({"failsafe_timeout": 5}, "failsafe_timeout", "needs failsafe"),
])
@pytest.mark.parametrize("component", [SimUavComponent, SimUgvComponent])
def test_simulator_tables_reject_bad_failsafe_settings(
        tmp_path: Path, component: Any, options: dict[str, Any], key: str, text: str) -> None:
    extra = {"broker_url": "mqtt://127.0.0.1:1"} if component is SimUgvComponent else {}
    with pytest.raises(ConfigError, match=text) as info:
        component().start(context(tmp_path, "sim", **options, **extra))
    assert info.value.key == key


def test_simulated_copter_starts_with_the_failsafe_of_its_table(tmp_path: Path) -> None:
    sim = SimUavComponent()
    sim.start(context(tmp_path, "sim_uav", failsafe="hold", failsafe_timeout=7))
    try:
        assert sim.uav is not None
        assert sim.uav.failsafe.enable == 7 and sim.uav.failsafe.watch.timeout_s == 7.0
    finally:
        sim.stop()
