"""The MAVLink link against a scripted vehicle: retries, timeouts, junk, hotspot texts."""

from __future__ import annotations

import socket
import threading
from collections.abc import Iterator
from typing import Any

import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from mrss.links.ardupilot import HotspotReport, format_hotspot, parse_hotspot
from mrss.links.errors import CommandTimeout
from mrss.links.mavconn import MAV, MavConnection
from mrss.links.mavlink import MavlinkLink
from mrss.testing import free_udp_port, wait_until


class SilentVehicle:
    """A vehicle that sends heartbeats and texts but never answers a command."""

    def __init__(self, port: int) -> None:
        self.conn = MavConnection(f"udpout:127.0.0.1:{port}", source_system=7,
                                  source_component=1)
        self.commands: list[Any] = []
        self.stop = threading.Event()
        self.thread = threading.Thread(target=self.run, daemon=True)
        self.thread.start()

    def run(self) -> None:
        mav = self.conn.conn.mav
        while not self.stop.is_set():
            self.conn.send(mav.heartbeat_encode(MAV.MAV_TYPE_QUADROTOR,
                                                MAV.MAV_AUTOPILOT_ARDUPILOTMEGA,
                                                MAV.MAV_MODE_FLAG_CUSTOM_MODE_ENABLED, 4, 3))
            deadline = 0.5
            while deadline > 0 and not self.stop.is_set():
                msg = self.conn.recv(timeout=0.05)
                deadline -= 0.05
                if msg is not None and msg.get_type() == "COMMAND_LONG":
                    self.commands.append(msg)

    def say(self, text: str) -> None:
        self.conn.send(self.conn.conn.mav.statustext_encode(MAV.MAV_SEVERITY_INFO,
                                                            text.encode()[:50]))

    def close(self) -> None:
        self.stop.set()
        self.thread.join(timeout=5)
        self.conn.close()


@pytest.fixture(scope="module")
def silent() -> Iterator[tuple[MavlinkLink, SilentVehicle, list[dict[str, Any]], int]]:
    port = free_udp_port()
    records: list[dict[str, Any]] = []
    link = MavlinkLink("uav7", f"udpin:127.0.0.1:{port}", command_timeout=0.3, retries=3,
                       on_telemetry=records.append)
    link.start()
    vehicle = SilentVehicle(port)
    try:
        link.wait_up(timeout=10)
        yield link, vehicle, records, port
    finally:
        vehicle.close()
        link.close()


def test_unanswered_command_is_retried_then_times_out(
        silent: tuple[MavlinkLink, SilentVehicle, list[dict[str, Any]], int]) -> None:
    link, vehicle, _, _ = silent
    assert link.target_system == 7 and link.mode == "GUIDED"
    before = len(vehicle.commands)
    with pytest.raises(CommandTimeout, match="after 3 attempts"):
        link.arm()
    wait_until(lambda: len(vehicle.commands) - before == 3, timeout=3, message="3 sends")
    sent = vehicle.commands[before:]
    assert [m.command for m in sent] == [MAV.MAV_CMD_COMPONENT_ARM_DISARM] * 3
    assert [m.confirmation for m in sent] == [0, 1, 2]  # MAVLink's retry counter
    assert all(m.target_system == 7 for m in sent)


def _sentinel(vehicle: SilentVehicle, records: list[dict[str, Any]], n: int) -> None:
    """Say a marker text until the link reports it: the link has read what came before."""
    text = f"SENTINEL {n}"
    tries = iter(range(1000))

    def seen() -> bool:
        if next(tries) % 100 == 0:  # every ~0.5 s: junk may have eaten an earlier one
            vehicle.say(text)
        return any(r.get("text") == text for r in list(records))

    wait_until(seen, timeout=5, message=text)


@settings(max_examples=60, deadline=None)
@given(junk=st.binary(min_size=1, max_size=280))
def test_junk_datagrams_never_crash_or_yield_telemetry(
        silent: tuple[MavlinkLink, SilentVehicle, list[dict[str, Any]], int],
        junk: bytes) -> None:
    link, vehicle, records, port = silent
    records.clear()
    with socket.socket(socket.AF_INET, socket.SOCK_DGRAM) as s:
        s.sendto(junk, ("127.0.0.1", port))
    _sentinel(vehicle, records, len(junk))
    assert {r["type"] for r in records} == {"text"}
    assert all(r["text"] == f"SENTINEL {len(junk)}" for r in records)
    assert link.up


@settings(max_examples=40, deadline=None)
@given(text=st.text(max_size=50))
def test_status_texts_become_hotspots_only_when_well_formed(
        silent: tuple[MavlinkLink, SilentVehicle, list[dict[str, Any]], int],
        text: str) -> None:
    link, vehicle, records, _ = silent
    records.clear()
    vehicle.say(text)
    _sentinel(vehicle, records, 0)
    spots = [r for r in records if r["type"] == "hotspot"]
    wire = text.encode()[:50].decode("utf-8", "ignore").rstrip("\x00")
    assert len(spots) == (1 if parse_hotspot(wire) is not None else 0)


def test_spoofed_absurd_telemetry_never_reaches_the_callbacks(
        silent: tuple[MavlinkLink, SilentVehicle, list[dict[str, Any]], int]) -> None:
    link, vehicle, records, _ = silent
    records.clear()
    mav = vehicle.conn.conn.mav
    before = link.rejections.total
    for remaining in (-128, 127):  # int8 battery_remaining: -1 is "unknown", not these
        vehicle.conn.send(mav.sys_status_encode(0, 0, 0, 500, 12000, 100, remaining,
                                                0, 0, 0, 0, 0, 0))
    vehicle.conn.send(mav.global_position_int_encode(0, 2_147_000_000, 0, 30_000, 1_000,
                                                     0, 0, 0, 0))  # lat 214.7
    vehicle.conn.send(mav.global_position_int_encode(0, -353_632_620, 1_491_652_370,
                                                     2_100_000_000, 1_000, 0, 0, 0, 0))
    _sentinel(vehicle, records, 1)
    assert not [r for r in records if r["type"] in ("battery", "position")], records
    assert link.latest("battery") is None and link.latest("position") is None
    assert link.rejections.total == before + 4
    assert set(link.rejections.stats()) >= {"uav7: battery.remaining out of range",
                                            "uav7: position.lat out of range",
                                            "uav7: position.alt out of range"}
    assert link.up


@given(text=st.text(max_size=80))
def test_parse_hotspot_never_raises(text: str) -> None:
    report = parse_hotspot(text)
    assert report is None or (-90 <= report.lat <= 90 and -180 <= report.lon <= 180)


@given(ident=st.integers(1, 99999), lat=st.floats(-90, 90), lon=st.floats(-180, 180),
       temp=st.floats(-50, 2000))
def test_hotspot_reports_round_trip(ident: int, lat: float, lon: float, temp: float) -> None:
    text = format_hotspot(HotspotReport(ident, lat, lon, temp))
    assert len(text) <= 50
    back = parse_hotspot(text)
    assert back is not None and back.id == ident
    assert back.lat == pytest.approx(lat, abs=1e-7) and back.lon == pytest.approx(lon, abs=1e-7)
    assert back.temperature == pytest.approx(round(temp), abs=0.5)
