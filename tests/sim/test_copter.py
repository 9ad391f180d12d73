"""The simulated copter's flight model: ArduCopter's rules, kinematics and battery."""

from __future__ import annotations

import pytest

from mrss.links.ardupilot import COPTER_MODES
from mrss.links.geo import distance_m, offset
from mrss.links.mavconn import MAV
from mrss.sim.copter import GUIDED, LAND, RTL, CopterModel, NavItem, Refused

HOME = (-35.363262, 149.165237)


def fly(model: CopterModel, seconds: float, dt: float = 0.1) -> None:
    for _ in range(round(seconds / dt)):
        model.step(dt)


def airborne(alt: float = 10.0) -> CopterModel:
    m = CopterModel(*HOME, 584.0)
    m.set_mode(GUIDED)
    m.arm()
    m.takeoff(alt)
    fly(m, alt / m.params.climb_mps + 1)
    return m


def test_arming_follows_arducopter_mode_rules() -> None:
    m = CopterModel(*HOME)
    for mode in ("AUTO", "RTL", "LAND"):
        m.set_mode(COPTER_MODES[mode])
        with pytest.raises(Refused, match="Mode not armable"):
            m.arm()
    m.set_mode(COPTER_MODES["LOITER"])
    m.arm()
    assert m.armed
    m.arm()  # arming an armed vehicle is accepted, as ArduPilot does


def test_unknown_mode_is_refused() -> None:
    with pytest.raises(Refused, match="Unknown mode 42"):
        CopterModel(*HOME).set_mode(42)


def test_takeoff_needs_guided_armed_and_ground() -> None:
    m = CopterModel(*HOME)
    with pytest.raises(Refused, match="not in GUIDED"):
        m.takeoff(10)
    m.set_mode(GUIDED)
    with pytest.raises(Refused, match="not armed"):
        m.takeoff(10)
    m.arm()
    m.takeoff(10)
    with pytest.raises(Refused, match="already flying"):
        m.takeoff(20)
    fly(m, 3.0)
    assert m.alt == pytest.approx(7.5)  # climbs at 2.5 m/s
    fly(m, 2.0)
    assert m.alt == 10.0 and not m.landed


def test_goto_moves_at_the_speed_limit_and_stops_on_target() -> None:
    m = airborne()
    target = offset(*HOME, 100.0, 0.0)
    m.goto(target[0], target[1], 10.0)
    fly(m, 5.0)
    assert distance_m(*HOME, m.lat, m.lon) == pytest.approx(50.0, rel=0.01)
    assert m.velocity[0] == pytest.approx(10.0, rel=0.01)
    assert m.heading == pytest.approx(0.0, abs=0.5)
    fly(m, 6.0)
    assert (m.lat, m.lon) == target


def test_disarm_in_flight_is_refused_unless_forced() -> None:
    m = airborne()
    with pytest.raises(Refused, match="flying"):
        m.disarm()
    m.disarm(force=True)
    assert not m.armed and m.landed and m.alt == 0.0


def test_rtl_climbs_flies_home_lands_and_disarms() -> None:
    m = airborne(5.0)
    away = offset(*HOME, 0.0, 60.0)
    m.goto(away[0], away[1], 5.0)
    fly(m, 10.0)
    m.set_mode(RTL)
    fly(m, 2.0)
    assert m.alt > 5.0 and distance_m(*HOME, m.lat, m.lon) == pytest.approx(60.0, abs=0.5)
    fly(m, 60.0)
    assert m.landed and not m.armed
    assert distance_m(*HOME, m.lat, m.lon) < 1.0


def test_land_descends_where_it_is_and_disarms() -> None:
    m = airborne(12.0)
    m.set_mode(LAND)
    fly(m, 1.0)
    assert m.alt == pytest.approx(10.5)  # 1.5 m/s above 10 m
    fly(m, 30.0)
    assert m.landed and not m.armed and (m.lat, m.lon) == HOME


def test_mission_flies_items_in_order_and_reports_each() -> None:
    m = CopterModel(*HOME, 584.0)
    wp = offset(*HOME, 30.0, 0.0)
    m.mission = [NavItem(0, MAV.MAV_CMD_NAV_WAYPOINT),
                 NavItem(1, MAV.MAV_CMD_NAV_TAKEOFF, alt=10.0),
                 NavItem(2, MAV.MAV_CMD_NAV_WAYPOINT, lat=wp[0], lon=wp[1], alt=594.0,
                         frame=MAV.MAV_FRAME_GLOBAL),  # absolute altitude: 10 m above home
                 NavItem(3, MAV.MAV_CMD_NAV_LAND)]
    m.set_mode(GUIDED)
    m.arm()
    m.set_mode(COPTER_MODES["AUTO"])
    fly(m, 6.0)
    assert m.reached == [1] and m.alt == 10.0
    fly(m, 5.0)
    assert m.reached == [1, 2] and distance_m(m.lat, m.lon, *wp) < 1.0
    fly(m, 30.0)
    assert m.reached == [1, 2, 3] and m.landed and not m.armed
    assert (MAV.MAV_SEVERITY_INFO, "Mission complete") in m.texts


def test_auto_on_the_ground_needs_a_takeoff_item() -> None:
    m = CopterModel(*HOME)
    m.mission = [NavItem(0, MAV.MAV_CMD_NAV_WAYPOINT), NavItem(1, MAV.MAV_CMD_NAV_WAYPOINT)]
    m.set_mode(GUIDED)
    m.arm()
    with pytest.raises(Refused, match="Missing Takeoff"):
        m.set_mode(COPTER_MODES["AUTO"])


def test_battery_drains_only_when_armed_and_faster_in_flight() -> None:
    m = CopterModel(*HOME)
    fly(m, 100.0, dt=1.0)
    assert m.battery_pct == 100.0
    m.set_mode(GUIDED)
    m.arm()
    fly(m, 120.0, dt=1.0)
    on_ground = 100.0 - m.battery_pct
    m.takeoff(10)
    fly(m, 120.0, dt=1.0)
    in_air = 100.0 - m.battery_pct - on_ground
    assert in_air == pytest.approx(10.0, rel=0.01)  # 1200 s endurance: 120 s = 10 %
    assert on_ground == pytest.approx(0.5, rel=0.01)


def test_low_battery_triggers_return_to_launch() -> None:
    m = airborne()
    m.battery_pct = 10.5
    fly(m, 10.0, dt=1.0)
    assert m.mode == RTL
    assert any("failsafe" in text for _, text in m.texts)
