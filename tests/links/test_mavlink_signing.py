"""MAVLink 2 signing over real UDP: only messages signed with the robot's key get through.

The link and the simulated vehicle each sign what they send and refuse what is not
signed with their key (mrss.links.mavlink_signing): unsigned, wrongly signed and
replayed messages are counted, never handled.
"""

from __future__ import annotations

import logging
import re
import secrets
import socket
import threading
import time
from collections.abc import Iterator
from pathlib import Path
from typing import Any

import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from mrss.errors import ConfigError
from mrss.links.errors import CommandTimeout, LinkDown
from mrss.links.factory import create_link
from mrss.links.geo import offset
from mrss.links.mavconn import MAV, MavConnection
from mrss.links.mavlink import MavlinkLink
from mrss.links.mavlink_signing import load_key
from mrss.logs import AppendFileHandler, LineFormatter
from mrss.testing import free_udp_port, wait_until

from .conftest import Spawn

HOME = (-35.363262, 149.165237)
SYSID = 9


def key_file(folder: Path, name: str = "uav.key") -> tuple[Path, bytes]:
    key = secrets.token_bytes(32)
    path = folder / name
    path.write_text(key.hex() + "\n", encoding="ascii")
    path.chmod(0o600)
    return path, key


class Vehicle:
    """A scripted vehicle that sends signed heartbeats (and texts on demand)."""

    def __init__(self, port: int, key: bytes | None) -> None:
        self.conn = MavConnection(f"udpout:127.0.0.1:{port}", source_system=SYSID,
                                  source_component=1, signing_key=key)
        self.stop = threading.Event()
        self.thread = threading.Thread(target=self.run, daemon=True)
        self.thread.start()

    def run(self) -> None:
        mav = self.conn.conn.mav
        while not self.stop.is_set():
            self.conn.send(mav.heartbeat_encode(MAV.MAV_TYPE_QUADROTOR,
                                                MAV.MAV_AUTOPILOT_ARDUPILOTMEGA,
                                                MAV.MAV_MODE_FLAG_CUSTOM_MODE_ENABLED, 4, 3))
            self.stop.wait(0.3)

    def close(self) -> None:
        self.stop.set()
        self.thread.join(timeout=5)
        self.conn.close()


def say(conn: MavConnection, text: str) -> None:
    conn.send(conn.conn.mav.statustext_encode(MAV.MAV_SEVERITY_INFO, text.encode()))


def texts(records: list[dict[str, Any]]) -> list[str]:
    return [r["text"] for r in list(records) if r["type"] == "text"]


@pytest.fixture()
def signed_link(tmp_path: Path) -> Iterator[tuple[MavlinkLink, list[dict[str, Any]], int,
                                                  bytes]]:
    path, key = key_file(tmp_path)
    port = free_udp_port()
    records: list[dict[str, Any]] = []
    link = create_link("uav9", "mavlink", {"url": f"udpin:127.0.0.1:{port}",
                                           "signing_key": str(path)},
                       on_telemetry=records.append)
    assert isinstance(link, MavlinkLink) and link.signed
    link.start()
    vehicle = Vehicle(port, key)
    try:
        link.wait_up(timeout=10)
        yield link, records, port, key
    finally:
        vehicle.close()
        link.close()


def test_unsigned_and_wrongly_signed_statustexts_are_refused_a_signed_one_passes(
        signed_link: tuple[MavlinkLink, list[dict[str, Any]], int, bytes]) -> None:
    link, records, port, key = signed_link
    assert link.target_system == SYSID
    unsigned = MavConnection(f"udpout:127.0.0.1:{port}", source_system=SYSID,
                             source_component=1)
    wrong = MavConnection(f"udpout:127.0.0.1:{port}", source_system=SYSID,
                          source_component=1, signing_key=secrets.token_bytes(32))
    genuine = MavConnection(f"udpout:127.0.0.1:{port}", source_system=SYSID,
                            source_component=1, signing_key=key)
    try:
        say(unsigned, "spoof: unsigned")
        say(wrong, "spoof: wrong key")
        say(genuine, "signed hello")
        wait_until(lambda: "signed hello" in texts(records), timeout=5,
                   message="the signed text")
        wait_until(lambda: link.refused()["unsigned"] >= 1
                   and link.refused()["bad signature"] >= 1, timeout=5,
                   message="both refusals counted")
    finally:
        for conn in (unsigned, wrong, genuine):
            conn.close()
    assert texts(records) == ["signed hello"]
    assert link.up and link.refused()["replayed"] == 0


def refusals_told(log_text: str) -> int:
    """How many MAVLink refusals a log tells of: one per first line of an interval, and
    the number of each summary line."""
    return log_text.count("refused MAVLink message from ") + sum(
        int(n) for n in re.findall(r"refused (\d+) more MAVLink message\(s\)", log_text))


def test_a_flood_of_refusals_is_logged_once_per_interval_and_every_one_is_told(
        signed_link: tuple[MavlinkLink, list[dict[str, Any]], int, bytes],
        tmp_path: Path) -> None:
    """Issue 29: a flood was counted (2,592) but the log told of 1. Now the first refusal
    of the interval is a line, the rest one summary line with their number (when the
    interval is over, or the link closes): the log adds up to the count."""
    link, _, port, _ = signed_link
    log_file = tmp_path / "mrss.log"
    handler = AppendFileHandler(log_file)
    handler.setFormatter(LineFormatter("rcl"))
    logging.getLogger().addHandler(handler)
    spoofer = MavConnection(f"udpout:127.0.0.1:{port}", source_system=SYSID,
                            source_component=1)
    try:
        for n in range(30):
            say(spoofer, f"spoof {n}")
        wait_until(lambda: link.refused()["unsigned"] >= 30, timeout=10,
                   message="30 refusals")
        link.close()  # what the interval held back is told now
    finally:
        spoofer.close()
        logging.getLogger().removeHandler(handler)
        handler.close()
    text = log_file.read_text()
    assert refusals_told(text) == link.refused()["unsigned"] >= 30
    assert len(text.splitlines()) <= 4, text   # not a line per message
    assert "Traceback" not in text


def test_a_replayed_signed_datagram_is_refused(
        signed_link: tuple[MavlinkLink, list[dict[str, Any]], int, bytes]) -> None:
    link, records, port, key = signed_link
    sender = MavConnection("udpout:127.0.0.1:9", source_system=SYSID, source_component=1,
                           signing_key=key)  # only its codec: the datagram goes out below
    packet = bytes(sender.conn.mav.statustext_encode(MAV.MAV_SEVERITY_INFO,
                                                     b"once only").pack(sender.conn.mav))
    sender.close()
    with socket.socket(socket.AF_INET, socket.SOCK_DGRAM) as sock:
        sock.sendto(packet, ("127.0.0.1", port))
        wait_until(lambda: "once only" in texts(records), timeout=5, message="first copy")
        sock.sendto(packet, ("127.0.0.1", port))
        wait_until(lambda: link.refused()["replayed"] == 1, timeout=5,
                   message="the copy refused")
    assert texts(records) == ["once only"]


def test_a_forged_far_future_timestamp_does_not_lock_the_vehicle_out(
        signed_link: tuple[MavlinkLink, list[dict[str, Any]], int, bytes]) -> None:
    link, records, port, key = signed_link
    forger = MavConnection(f"udpout:127.0.0.1:{port}", source_system=SYSID,
                           source_component=1, signing_key=secrets.token_bytes(32))
    genuine = MavConnection(f"udpout:127.0.0.1:{port}", source_system=SYSID,
                            source_component=1, signing_key=key)
    assert forger.signing is not None and genuine.signing is not None
    forger.signing.state.link_id = genuine.signing.state.link_id  # the same stream
    forger.signing.state.timestamp = genuine.signing.state.timestamp + 10**12
    try:
        say(forger, "forged")
        wait_until(lambda: link.refused()["bad signature"] == 1, timeout=5,
                   message="forgery refused")
        say(genuine, "still heard")
        wait_until(lambda: "still heard" in texts(records), timeout=5,
                   message="the genuine text after the forgery")
    finally:
        forger.close()
        genuine.close()
    assert "forged" not in texts(records)


def test_a_signed_link_never_comes_up_on_an_unsigned_vehicle(tmp_path: Path) -> None:
    path, _ = key_file(tmp_path)
    port = free_udp_port()
    link = MavlinkLink("uav9", f"udpin:127.0.0.1:{port}", signing_key=load_key(path))
    link.start()
    vehicle = Vehicle(port, None)
    try:
        wait_until(lambda: link.refused()["unsigned"] >= 3, timeout=10,
                   message="heartbeats refused")
        wait_until(lambda: "not signed with this link's key" in link.reason, timeout=10,
                   message="the reason names the refusals")
        with pytest.raises(LinkDown, match=r"waiting for first heartbeat; refused \d+ "
                                           r"messages not signed with this link's key "
                                           r"\(\d+ unsigned\)"):
            link.wait_up(timeout=0.1)
        assert link.target_system is None
    finally:
        vehicle.close()
        link.close()


def start_uav(spawn: Spawn, port: int, key: Path) -> Any:
    return spawn("mrss", "sim", "uav", "--out", f"udpout:127.0.0.1:{port}", "--speedup", "20",
                 f"--home={HOME[0]},{HOME[1]},584", f"--signing-key={key}")


@pytest.mark.slow
def test_signed_simulator_and_link_take_off_and_fly_to_a_point(spawn: Spawn,
                                                                tmp_path: Path) -> None:
    path, key = key_file(tmp_path)
    port = free_udp_port()
    start_uav(spawn, port, path)
    link = MavlinkLink("uav1", f"udpin:127.0.0.1:{port}", signing_key=key)
    link.start()
    try:
        link.wait_up(timeout=15)
        link.set_mode("GUIDED")
        link.arm()
        link.takeoff(20)
        link.wait_arrival(*HOME, 20, tolerance_m=0.5, timeout=20)
        wait_until(lambda: link.landed is False, timeout=5, message="in the air")
        far = offset(*HOME, 100.0, 0.0)
        link.goto(far[0], far[1], 20)
        link.wait_arrival(far[0], far[1], 20, tolerance_m=1.0, timeout=30)
        assert link.refused() == {"unsigned": 0, "bad signature": 0, "replayed": 0}
    finally:
        link.close()


def test_a_signed_simulator_ignores_an_unsigned_links_commands(spawn: Spawn,
                                                               tmp_path: Path) -> None:
    path, _ = key_file(tmp_path)
    port = free_udp_port()
    proc = start_uav(spawn, port, path)
    link = MavlinkLink("uav1", f"udpin:127.0.0.1:{port}", command_timeout=0.5, retries=2)
    link.start()
    try:
        link.wait_up(timeout=15)  # a link without a key reads signed messages
        with pytest.raises(CommandTimeout):
            link.set_mode("GUIDED")
        assert link.mode == "STABILIZE" and not link.armed  # as the vehicle reports
    finally:
        link.close()
    log = tmp_path / "proc-0.log"
    wait_until(lambda: "refused MAVLink message" in log.read_text(errors="replace"),
               timeout=15, message="the vehicle logs its refusals")
    text = log.read_text(errors="replace")
    assert "unsigned" in text and "Traceback" not in text
    assert proc.poll() is None


@pytest.mark.parametrize(("content", "message"), [
    (b"", "must hold 32 bytes as 64 hexadecimal characters"),
    (b"zz" * 32, "must hold 32 bytes"),
    (bytes(range(200, 232)), "must hold 32 bytes"),  # raw bytes are not the format
    (b"00" * 32, "all-zero key"),
])
def test_bad_key_files_are_refused_naming_the_option(tmp_path: Path, content: bytes,
                                                     message: str) -> None:
    path = tmp_path / "bad.key"
    path.write_bytes(content)
    with pytest.raises(ConfigError, match=message) as caught:
        create_link("uav1", "mavlink", {"url": "udpin:127.0.0.1:14550",
                                        "signing_key": str(path)}, source="project.toml")
    assert caught.value.key == "signing_key" and caught.value.file == "project.toml"
    with pytest.raises(ConfigError, match="cannot read signing key file"):
        create_link("uav1", "mavlink", {"url": "udpin:127.0.0.1:14550",
                                        "signing_key": str(tmp_path / "none.key")})


@pytest.fixture(scope="module")
def fuzzed(tmp_path_factory: pytest.TempPathFactory
           ) -> Iterator[tuple[MavlinkLink, list[dict[str, Any]], int, MavConnection]]:
    path, key = key_file(tmp_path_factory.mktemp("fuzz"))
    port = free_udp_port()
    records: list[dict[str, Any]] = []
    link = MavlinkLink("uav9", f"udpin:127.0.0.1:{port}", signing_key=load_key(path),
                       on_telemetry=records.append)
    link.start()
    vehicle = Vehicle(port, key)
    try:
        link.wait_up(timeout=10)
        yield link, records, port, vehicle.conn
    finally:
        vehicle.close()
        link.close()


@settings(max_examples=60, deadline=None)
@given(where=st.integers(0, 200), flip=st.integers(1, 255))
def test_a_signed_message_altered_in_any_byte_is_refused(
        fuzzed: tuple[MavlinkLink, list[dict[str, Any]], int, MavConnection],
        where: int, flip: int) -> None:
    link, records, port, genuine = fuzzed
    mav = genuine.conn.mav
    with genuine._send_lock:  # the vehicle thread signs with the same state
        packet = bytearray(mav.statustext_encode(
            MAV.MAV_SEVERITY_NOTICE, b"HOTSPOT 7 -35.3625430 149.1652370 400").pack(mav))
    packet[where % len(packet)] ^= flip
    records.clear()
    with socket.socket(socket.AF_INET, socket.SOCK_DGRAM) as sock:
        sock.sendto(bytes(packet), ("127.0.0.1", port))
    sentinel = f"SENTINEL {where}.{flip}"
    sent_at = [0.0]

    def heard() -> bool:  # said again every 0.5 s, should a datagram be lost
        if time.monotonic() - sent_at[0] > 0.5:
            sent_at[0] = time.monotonic()
            say(genuine, sentinel)
        return sentinel in texts(records)
    wait_until(heard, timeout=10, message=sentinel)
    assert not [r for r in list(records) if r["type"] == "hotspot"]
    assert set(texts(records)) == {sentinel} and link.up
