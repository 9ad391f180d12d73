"""The UAV's GCS failsafe, end to end: a MAVLink link in its own process over real UDP.

The simulated copter runs in the test (it is the physical robot; its state is read
directly), the link in a separate process that is stopped, killed or loses its
controller. Nothing waits on time: every step waits on a condition.
"""

from __future__ import annotations

import signal
from collections.abc import Iterator
from pathlib import Path

import pytest

from mrss.links.geo import distance_m, offset
from mrss.ports import free_udp_port
from mrss.sim.uav import SimUav, UavSnapshot
from mrss.testing import wait_until

from .failsafe_driver import LinkProcess

HOME = (-35.363262, 149.165237, 584.0)
FAR = offset(HOME[0], HOME[1], 2000.0, 0.0)   # never reached during a test
ALT = 10.0
TIMEOUT_S = 4.0   # failsafe_timeout: well above the 1 s heartbeat period on a busy machine
WAIT = 60.0


@pytest.fixture()
def uav() -> Iterator[tuple[SimUav, int]]:
    port = free_udp_port()
    sim = SimUav(f"udpin:127.0.0.1:{port}", home=HOME, speedup=10.0)  # no failsafe of its own
    sim.start()
    try:
        yield sim, port
    finally:
        sim.stop()


@pytest.fixture()
def links(tmp_path: Path) -> Iterator[list[LinkProcess]]:
    started: list[LinkProcess] = []
    try:
        yield started
    finally:
        for proc in started:
            proc.close()


def start_link(links: list[LinkProcess], tmp_path: Path, port: int, failsafe: str
               ) -> LinkProcess:
    proc = LinkProcess(tmp_path / f"link-{len(links)}.log", "mavlink", "uav1",
                       {"url": f"udpout:127.0.0.1:{port}", "failsafe": failsafe,
                        "failsafe_timeout": TIMEOUT_S, "heartbeat_timeout": 3.0})
    links.append(proc)
    return proc


def snap(sim: SimUav) -> UavSnapshot:
    return sim.snapshot()


def configured_and_flying(sim: SimUav, link: LinkProcess, enable: int) -> None:
    """The link set FS_GCS_* (confirmed by PARAM_VALUE); the copter flies towards FAR."""
    wait_until(lambda: any(r["event"] == "configured" for r in link.telemetry("failsafe")),
               timeout=WAIT, message="failsafe configured")
    assert sim.failsafe.enable == enable
    assert sim.failsafe.watch.timeout_s == TIMEOUT_S
    link.call("wait_up", 20)
    link.call("set_mode", "GUIDED")
    link.call("arm")
    link.call("takeoff", ALT)
    wait_until(lambda: snap(sim).alt >= ALT - 0.5, timeout=WAIT, message="takeoff")
    link.call("goto", FAR[0], FAR[1], ALT)
    start = snap(sim)
    wait_until(lambda: distance_m(snap(sim).lat, snap(sim).lon, start.lat, start.lon) > 5,
               timeout=WAIT, message="flying towards the far point")
    assert not snap(sim).failsafe


def holds_position(sim: SimUav) -> None:
    """Simulated time moves on and the copter does not."""
    before, clock = snap(sim), sim._sim_time
    wait_until(lambda: sim._sim_time > clock + 3.0, timeout=WAIT, message="3 s simulated")
    after = snap(sim)
    assert distance_m(before.lat, before.lon, after.lat, after.lon) < 0.1
    assert after.mode == "BRAKE"


def failsafe_reported_then_up(link: LinkProcess, since: int = 0) -> tuple[str, str]:
    """The link said "down: failsafe ..." and then up again; returns both reasons."""
    def pair() -> tuple[str, str] | None:
        states = link.states()[since:]
        for i, (up, why) in enumerate(states):
            if not up and why.startswith("failsafe: "):
                ups = [w for u, w in states[i + 1:] if u]
                if ups:
                    return why, ups[0]
        return None
    found = wait_until(pair, timeout=WAIT, message="failsafe reported, then link up")
    return found


def test_sigstopped_link_copter_brakes_then_obeys_a_new_command(
        uav: tuple[SimUav, int], links: list[LinkProcess], tmp_path: Path) -> None:
    sim, port = uav
    assert sim.failsafe.enable == 0  # the link's PARAM_SETs turn it on
    link = start_link(links, tmp_path, port, "hold")
    configured_and_flying(sim, link, enable=7)

    link.signal(signal.SIGSTOP)  # the controller freezes: no more GCS heartbeats
    wait_until(lambda: snap(sim).failsafe and snap(sim).mode == "BRAKE", timeout=WAIT,
               message="GCS failsafe: BRAKE")
    holds_position(sim)
    assert sim.failsafe.fired == 1

    link.signal(signal.SIGCONT)
    down, up = failsafe_reported_then_up(link)
    assert "GCS Failsafe" in down
    assert up == "control regained after a failsafe; vehicle in BRAKE"
    wait_until(lambda: not snap(sim).failsafe, timeout=WAIT, message="failsafe cleared")
    assert snap(sim).mode == "BRAKE"  # as ArduCopter: the failsafe mode stays
    assert link.telemetry("status")[-1]["mode"] == "BRAKE"
    events = [r["event"] for r in link.telemetry("failsafe")]
    assert events[0] == "configured" and events.count("triggered") == 1
    assert events.index("regained") > events.index("triggered")
    # the stalled link read the vehicle's news before judging it silent: the only
    # down it reported is the failsafe
    assert [why for up, why in link.states() if not up] == [down]

    link.call("set_mode", "GUIDED")  # a new command takes effect: 30 m east of the brake
    near = offset(snap(sim).lat, snap(sim).lon, 0.0, 30.0)
    link.call("goto", near[0], near[1], ALT)
    wait_until(lambda: distance_m(snap(sim).lat, snap(sim).lon, *near) < 2, timeout=WAIT,
               message="arrival at the new target")
    assert snap(sim).mode == "GUIDED" and sim.failsafe.fired == 1


def test_sigkilled_link_copter_lands_and_a_new_link_hears_of_the_failsafe(
        uav: tuple[SimUav, int], links: list[LinkProcess], tmp_path: Path) -> None:
    sim, port = uav
    link = start_link(links, tmp_path, port, "stop")
    configured_and_flying(sim, link, enable=5)

    link.signal(signal.SIGKILL)
    wait_until(lambda: snap(sim).mode == "LAND" and snap(sim).failsafe, timeout=WAIT,
               message="GCS failsafe: LAND")
    wait_until(lambda: snap(sim).landed and not snap(sim).armed, timeout=WAIT,
               message="landed and disarmed")

    second = start_link(links, tmp_path, port, "stop")  # a new incarnation of the link
    down, up = failsafe_reported_then_up(second)
    assert "GCS Failsafe Cleared" in down
    assert up == "control regained after a failsafe; vehicle in LAND"
    assert not snap(sim).failsafe and snap(sim).mode == "LAND"

    second.call("set_mode", "GUIDED")
    second.call("arm")
    second.call("takeoff", ALT)
    wait_until(lambda: snap(sim).alt >= ALT - 0.5, timeout=WAIT, message="new takeoff")


def test_link_without_a_live_controller_stops_heartbeats_and_copter_returns_home(
        uav: tuple[SimUav, int], links: list[LinkProcess], tmp_path: Path) -> None:
    sim, port = uav
    link = start_link(links, tmp_path, port, "rtl")
    configured_and_flying(sim, link, enable=1)

    link.call("controller", False)  # the robot actor is gone: the link stays, silent
    wait_until(lambda: snap(sim).mode == "RTL" and snap(sim).failsafe, timeout=WAIT,
               message="GCS failsafe: RTL")
    wait_until(lambda: any(not up and why.startswith("failsafe: ")
                           for up, why in link.states()), timeout=WAIT,
               message="failsafe reported while the vehicle is still heard")
    assert link.states()[-1][0] is False  # down until the vehicle hears us again

    link.call("controller", True)
    failsafe_reported_then_up(link)
    wait_until(lambda: not snap(sim).failsafe, timeout=WAIT, message="failsafe cleared")
    assert snap(sim).mode == "RTL"
