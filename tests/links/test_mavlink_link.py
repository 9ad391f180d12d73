"""The MAVLink link against the simulated UAV in its own process, over real UDP."""

from __future__ import annotations

import signal
from collections.abc import Iterator
from typing import Any

import pytest

from mrss.links.errors import CommandRejected, LinkDown
from mrss.links.geo import offset
from mrss.links.mavlink import MavlinkLink
from mrss.links.mavlink_mission import MissionItem
from mrss.testing import free_udp_port, wait_until

from .conftest import Spawn
from .sample_scopes import ScopeRecorder

HOME = (-35.363262, 149.165237)
HOTSPOT = offset(*HOME, 80.0, 0.0)  # 80 m north of home


class Recorder:
    """Collects what a link reports through its callbacks."""

    def __init__(self) -> None:
        self.states: list[tuple[bool, str]] = []
        self.telemetry: list[dict[str, Any]] = []

    def on_state(self, up: bool, reason: str) -> None:
        self.states.append((up, reason))

    def on_telemetry(self, record: dict[str, Any]) -> None:
        self.telemetry.append(record)

    def of_type(self, kind: str) -> list[dict[str, Any]]:
        return [r for r in list(self.telemetry) if r["type"] == kind]


def start_uav(spawn: Spawn, port: int) -> Any:
    return spawn("mrss", "sim", "uav", "--out", f"udpout:127.0.0.1:{port}", "--speedup", "20",
                 f"--home={HOME[0]},{HOME[1]},584", f"--hotspots={HOTSPOT[0]},{HOTSPOT[1]}")


@pytest.fixture()
def uav(spawn: Spawn) -> Iterator[tuple[MavlinkLink, Recorder, Any, int]]:
    port = free_udp_port()
    proc = start_uav(spawn, port)
    rec = Recorder()
    link = MavlinkLink("uav1", f"udpin:127.0.0.1:{port}", on_link_state=rec.on_state,
                       on_telemetry=rec.on_telemetry)
    link.start()
    try:
        link.wait_up(timeout=15)
        yield link, rec, proc, port
    finally:
        link.close()


def test_link_comes_up_and_reports_vehicle_state(uav: tuple[MavlinkLink, Recorder, Any, int]
                                                 ) -> None:
    link, rec, _, _ = uav
    assert rec.states[-1][0] is True and "heartbeat" in rec.states[-1][1]
    assert link.target_system == 1
    wait_until(lambda: rec.of_type("position") and rec.of_type("battery")
               and link.landed is not None, timeout=5, message="first telemetry")
    pos = rec.of_type("position")[-1]
    assert pos["lat"] == pytest.approx(HOME[0], abs=1e-6)
    assert pos["alt"] == pytest.approx(584.0, abs=0.01) and pos["relative_alt"] == 0.0
    assert rec.of_type("battery")[-1]["remaining"] == 100.0
    assert link.mode == "STABILIZE" and not link.armed and link.landed


@pytest.mark.slow
def test_arm_takeoff_goto_detects_hotspot_then_rtl_lands(
        uav: tuple[MavlinkLink, Recorder, Any, int]) -> None:
    link, rec, _, _ = uav
    link.set_mode("GUIDED")
    link.arm()
    link.takeoff(20)
    link.wait_arrival(*HOME, 20, tolerance_m=0.5, timeout=20)
    wait_until(lambda: link.landed is False, timeout=5, message="in the air")
    far = offset(*HOME, 150.0, 0.0)
    link.goto(far[0], far[1], 20)
    link.wait_arrival(far[0], far[1], 20, tolerance_m=1.0, timeout=30)
    spots = rec.of_type("hotspot")
    assert len(spots) == 1
    assert spots[0]["lat"] == pytest.approx(HOTSPOT[0], abs=1e-6) and spots[0]["id"] == 1
    battery = rec.of_type("battery")[-1]["remaining"]
    assert battery < 100.0  # drained by the flight
    link.return_to_launch()
    link.wait_landed(timeout=60)
    pos = link.latest("position")
    assert pos is not None and pos["relative_alt"] == pytest.approx(0.0, abs=0.01)
    assert pos["lat"] == pytest.approx(HOME[0], abs=1e-5)
    assert rec.of_type("status")[-1]["mode"] == "RTL"


def test_refusals_raise_command_rejected_with_the_vehicles_reason(
        uav: tuple[MavlinkLink, Recorder, Any, int]) -> None:
    link, _, _, _ = uav
    link.set_mode("LAND")
    with pytest.raises(CommandRejected, match="Mode not armable"):
        link.arm()
    link.set_mode("GUIDED")
    with pytest.raises(CommandRejected, match="not armed"):
        link.takeoff(10)
    with pytest.raises(CommandRejected, match="on the ground"):
        link.goto(*HOME, 10)
    with pytest.raises(ValueError):
        link.set_mode("NO_SUCH_MODE")
    link.arm()
    wait_until(lambda: link.armed, timeout=3, message="armed")


@pytest.mark.slow
def test_mission_upload_flies_in_auto_and_lands(
        uav: tuple[MavlinkLink, Recorder, Any, int]) -> None:
    link, rec, _, _ = uav
    wp = offset(*HOME, 0.0, 60.0)
    link.upload_mission([MissionItem.takeoff(15), MissionItem.waypoint(wp[0], wp[1], 15, hold_s=20),
                         MissionItem.land()])
    link.set_mode("GUIDED")
    link.arm()
    link.start_mission()
    link.wait_arrival(wp[0], wp[1], 15, tolerance_m=1.0, timeout=30)
    link.wait_landed(timeout=60)
    reached = [r["reached"] for r in rec.of_type("mission") if r["reached"] is not None]
    assert reached == [1, 2, 3]
    pos = link.latest("position")
    assert pos is not None and pos["lon"] == pytest.approx(wp[1], abs=1e-5)


def test_auto_without_takeoff_item_is_refused_on_the_ground(
        uav: tuple[MavlinkLink, Recorder, Any, int]) -> None:
    link, _, _, _ = uav
    link.upload_mission([MissionItem.waypoint(*HOME, 10)])
    link.set_mode("GUIDED")
    link.arm()
    with pytest.raises(CommandRejected, match="Missing Takeoff"):
        link.set_mode("AUTO")


@pytest.mark.slow
def test_link_down_when_sim_stopped_and_up_when_it_continues(
        uav: tuple[MavlinkLink, Recorder, Any, int]) -> None:
    link, rec, proc, _ = uav
    proc.send_signal(signal.SIGSTOP)
    try:
        wait_until(lambda: not link.up, timeout=10, message="link down")
        assert link.reason == "no heartbeat for 3.0 s"
        assert rec.states[-1] == (False, "no heartbeat for 3.0 s")
        with pytest.raises(LinkDown, match="no heartbeat"):
            link.arm()
    finally:
        proc.send_signal(signal.SIGCONT)
    link.wait_up(timeout=10)
    assert rec.states[-1][0] is True and "resumed" in rec.states[-1][1]
    link.set_mode("GUIDED")  # commands work again


@pytest.mark.slow
def test_link_down_when_sim_killed_and_up_when_restarted(
        spawn: Spawn, uav: tuple[MavlinkLink, Recorder, Any, int]) -> None:
    link, rec, proc, port = uav
    proc.kill()
    proc.wait()
    wait_until(lambda: not link.up, timeout=10, message="link down")
    assert "no heartbeat" in link.reason
    start_uav(spawn, port)
    link.wait_up(timeout=15)
    link.set_mode("GUIDED")
    link.arm()
    assert [up for up, _ in rec.states][-2:] == [False, True]


def test_records_read_together_are_handed_on_inside_one_scope(spawn: Spawn) -> None:
    """The RCL's publisher gathers what is published inside the link's sample scope into
    one bus message: a UDP link hands on every record inside a scope, those it read in
    one go inside the same one."""
    port = free_udp_port()
    start_uav(spawn, port)
    rec = ScopeRecorder()
    link = MavlinkLink("uav1", f"udpin:127.0.0.1:{port}", on_telemetry=rec.on_record)
    link.set_sample_scope(rec.scope)
    link.start()
    try:
        link.wait_up(timeout=15)
        wait_until(lambda: sum(s.count("position") for s in list(rec.scopes)) >= 10,
                   timeout=10, message="ten positions")
        assert rec.outside == []
        assert {"position", "battery"} <= {kind for s in list(rec.scopes) for kind in s}
    finally:
        link.close()
