"""The simulated UGV's model: driving, tank and pump, base, teleop, command answers."""

from __future__ import annotations

import pytest

from mrss.errors import DecodeError
from mrss.links.geo import distance_m, offset
from mrss.links.ugv_protocol import UgvAck, UgvCommand, parse_command
from mrss.sim.ugv_model import UgvModel, UgvParams

BASE = (-35.3635, 149.1650)


def run(model: UgvModel, seconds: float, dt: float = 0.1) -> list[UgvAck]:
    for _ in range(round(seconds / dt)):
        model.step(dt)
    return model.take_answers()


def test_goto_is_accepted_then_done_on_arrival() -> None:
    m = UgvModel("u", *BASE)
    target = offset(*BASE, 30.0, 0.0)
    m.apply(UgvCommand("goto", "g1", lat=target[0], lon=target[1]))
    assert m.take_answers() == [UgvAck("g1", "accepted")]
    answers = run(m, 5.0)
    assert answers == [] and distance_m(*BASE, m.lat, m.lon) == pytest.approx(15.0, rel=0.02)
    assert m.speed == pytest.approx(3.0) and m.mode == "goto"
    assert run(m, 6.0) == [UgvAck("g1", "done", "arrived")]
    assert (m.lat, m.lon) == target and m.mode == "idle" and m.battery < 100.0


def test_new_goto_cancels_the_running_one() -> None:
    m = UgvModel("u", *BASE)
    m.apply(UgvCommand("goto", "a", lat=-35.0, lon=149.0))
    m.apply(UgvCommand("goto", "b", lat=-35.1, lon=149.0))
    assert m.take_answers() == [UgvAck("a", "accepted"), UgvAck("a", "cancelled",
                                                                    "superseded by goto"),
                                UgvAck("b", "accepted")]


def test_pump_drains_the_tank_and_base_refills_it() -> None:
    m = UgvModel("u", *BASE, UgvParams(tank_capacity_l=50.0, pump_rate_lps=5.0,
                                      refill_rate_lps=10.0))
    field = offset(*BASE, 50.0, 0.0)
    m.apply(UgvCommand("goto", None, lat=field[0], lon=field[1]))
    run(m, 20.0)
    assert not m.at_base
    m.apply(UgvCommand("pump", "p1", on=True, litres=20.0))
    assert run(m, 4.1) == [UgvAck("p1", "accepted"), UgvAck("p1", "done", "delivered")]
    assert m.tank == pytest.approx(30.0) and not m.pumping
    m.apply(UgvCommand("pump", "p2", on=True))
    assert run(m, 10.0) == [UgvAck("p2", "accepted"), UgvAck("p2", "done", "tank empty")]
    assert m.tank == 0.0
    m.apply(UgvCommand("pump", "p3", on=True))
    assert m.take_answers() == [UgvAck("p3", "rejected", "tank empty")]
    run(m, 30.0)
    assert m.tank == 0.0  # no refill away from base
    m.apply(UgvCommand("return_to_base", "r"))
    assert run(m, 20.0)[-1] == UgvAck("r", "done", "arrived")
    run(m, 6.0)
    assert m.at_base and m.tank == 50.0


def test_teleop_blocks_autonomy_and_drives_on_demand() -> None:
    m = UgvModel("u", *BASE)
    m.apply(UgvCommand("drive", "d0", speed=1.0, heading=90.0))
    m.apply(UgvCommand("teleop", "t", on=True))
    m.apply(UgvCommand("goto", "g", lat=-35.0, lon=149.0))
    m.apply(UgvCommand("drive", "d1", speed=2.0, heading=90.0))
    assert [a.status for a in m.take_answers()] == ["rejected", "done", "rejected", "done"]
    run(m, 5.0)
    assert distance_m(*BASE, m.lat, m.lon) == pytest.approx(10.0, rel=0.01)
    assert m.lat == pytest.approx(BASE[0], abs=1e-7) and m.lon > BASE[1]


def test_stop_cancels_moves_and_pumping() -> None:
    m = UgvModel("u", *BASE)
    m.apply(UgvCommand("goto", "g", lat=-35.0, lon=149.0))
    m.apply(UgvCommand("pump", "p", on=True))
    m.take_answers()
    m.apply(UgvCommand("stop", "s"))
    assert m.take_answers() == [UgvAck("g", "cancelled", "stopped"),
                                UgvAck("p", "cancelled", "stopped"), UgvAck("s", "done")]
    assert not m.pumping and m.target is None and m.mode == "idle"


def test_empty_battery_stops_the_robot() -> None:
    m = UgvModel("u", *BASE, UgvParams(endurance_s=10.0))
    m.apply(UgvCommand("goto", "g", lat=-35.0, lon=149.0))
    answers = run(m, 12.0)
    assert answers[-1] == UgvAck("g", "failed", "battery empty")
    m.apply(UgvCommand("goto", "g2", lat=-35.0, lon=149.0))
    assert m.take_answers() == [UgvAck("g2", "rejected", "battery empty")]


def test_observe_reads_where_the_robot_stands_and_fills_sample_slots() -> None:
    m = UgvModel("rover", *BASE, params=UgvParams(sample_slots=1))
    m.apply(UgvCommand("observe", "o1", instrument="image"))
    m.apply(UgvCommand("observe", "o2", instrument="sample"))
    m.apply(UgvCommand("observe", "o3", instrument="sample"))
    assert m.take_answers() == [
        UgvAck("o1", "done", f"image #1 at {BASE[0]:.6f},{BASE[1]:.6f}"),
        UgvAck("o2", "done", f"sample #2 at {BASE[0]:.6f},{BASE[1]:.6f} in slot 1"),
        UgvAck("o3", "rejected", "no free sample slot (1 of 1 used)")]
    assert m.samples == 1


def test_observe_is_refused_while_the_robot_moves() -> None:
    m = UgvModel("rover", *BASE)
    target = offset(*BASE, 30.0, 0.0)
    m.apply(UgvCommand("goto", "g1", lat=target[0], lon=target[1]))
    run(m, 1.0)
    m.take_answers()
    m.apply(UgvCommand("observe", "o1", instrument="spectrum"))
    assert m.take_answers() == [
        UgvAck("o1", "rejected", "moving: instruments deploy only when the robot is stopped")]
    run(m, 12.0)                                   # arrived and stopped: allowed again
    m.apply(UgvCommand("observe", "o2", instrument="spectrum"))
    assert m.take_answers()[0].status == "done"


def test_observe_commands_parse_and_a_bad_instrument_is_named() -> None:
    command = parse_command(b'{"cmd": "observe", "id": "o1", "instrument": "radar"}')
    assert command == UgvCommand("observe", "o1", instrument="radar")
    assert parse_command(command.to_json()) == command
    with pytest.raises(DecodeError, match="unknown instrument 'laser'; known: image, "
                                          "spectrum, radar, sample"):
        parse_command(b'{"cmd": "observe", "instrument": "laser"}')
