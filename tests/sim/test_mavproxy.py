"""MAVProxy, a real ground station, flies the simulated UAV: it must see it, arm it and
change its mode, checked from the simulator's own state."""

from __future__ import annotations

import hashlib
import os
import subprocess
import sys
import threading
from collections.abc import Iterator

import pytest

from mrss.links.geo import offset
from mrss.sim.hotspots import Hotspot
from mrss.sim.uav import DEFAULT_HOME, SimUav
from mrss.testing import free_udp_port, wait_until

HOTSPOT = offset(DEFAULT_HOME[0], DEFAULT_HOME[1], 60.0, 40.0)


class MavProxy:
    """MAVProxy as a child process driven through its command line on stdin."""

    def __init__(self, master: str, state_dir: str) -> None:
        self.proc = subprocess.Popen(
            [sys.executable, "-m", "MAVProxy.mavproxy", f"--master={master}", "--no-state",
             f"--state-basedir={state_dir}"],
            stdin=subprocess.PIPE, stdout=subprocess.PIPE, stderr=subprocess.STDOUT,
            text=True, bufsize=1, cwd=state_dir, env=dict(os.environ, HOME=state_dir),
        )
        self.lines: list[str] = []
        self.reader = threading.Thread(target=self._read, daemon=True)
        self.reader.start()

    def _read(self) -> None:
        assert self.proc.stdout is not None
        for line in self.proc.stdout:
            self.lines.append(line)

    def said(self, text: str) -> bool:
        return any(text in line for line in list(self.lines))

    def type(self, command: str) -> None:
        assert self.proc.stdin is not None
        self.proc.stdin.write(command + "\n")
        self.proc.stdin.flush()

    def close(self) -> None:
        if self.proc.stdin is not None:
            self.proc.stdin.close()  # end of input: MAVProxy exits
        try:
            self.proc.wait(timeout=15)
        except subprocess.TimeoutExpired:
            self.proc.kill()
            self.proc.wait()
        self.reader.join(timeout=5)


@pytest.fixture()
def vehicle_and_gcs(tmp_path: object) -> Iterator[tuple[SimUav, MavProxy]]:
    port = free_udp_port()
    uav = SimUav(f"udpout:127.0.0.1:{port}", hotspots=[Hotspot(1, *HOTSPOT)], speedup=20)
    gcs = MavProxy(f"udpin:127.0.0.1:{port}", str(tmp_path))
    uav.start()
    try:
        yield uav, gcs
    finally:
        gcs.close()
        uav.stop()


@pytest.mark.slow
def test_mavproxy_sees_arms_flies_and_switches_modes(
        vehicle_and_gcs: tuple[SimUav, MavProxy]) -> None:
    uav, gcs = vehicle_and_gcs
    wait_until(lambda: gcs.said("Detected vehicle 1:1"), timeout=60,
               message="MAVProxy detects the vehicle")
    wait_until(lambda: gcs.said("STABILIZE>"), timeout=20, message="mode shown in prompt")
    gcs.type("mode GUIDED")
    wait_until(lambda: uav.snapshot().mode == "GUIDED", timeout=10, message="GUIDED")
    gcs.type("arm throttle")
    wait_until(lambda: uav.snapshot().armed, timeout=10, message="armed by MAVProxy")
    wait_until(lambda: gcs.said("ARMED"), timeout=10, message="MAVProxy sees it armed")
    gcs.type("takeoff 20")
    wait_until(lambda: uav.snapshot().alt == 20.0, timeout=20, message="at 20 m")
    gcs.type(f"guided {HOTSPOT[0]:.7f} {HOTSPOT[1]:.7f} 20")
    wait_until(lambda: uav.snapshot().hotspots_seen == {1}, timeout=20,
               message="flown over the hotspot")
    wait_until(lambda: gcs.said("HOTSPOT 1 "), timeout=10, message="MAVProxy shows it")
    gcs.type("mode LOITER")
    wait_until(lambda: uav.snapshot().mode == "LOITER", timeout=10, message="LOITER")
    gcs.type("mode RTL")
    wait_until(lambda: uav.snapshot().mode == "RTL", timeout=10, message="RTL")
    wait_until(lambda: uav.snapshot().landed and not uav.snapshot().armed, timeout=30,
               message="home, landed and disarmed, as ArduCopter does")
    assert gcs.said("Got COMMAND_ACK: DO_SET_MODE: ACCEPTED")
    assert gcs.said("Got COMMAND_ACK: COMPONENT_ARM_DISARM: ACCEPTED")
    assert not gcs.said("fence breach")


@pytest.mark.slow
def test_mavproxy_with_the_passphrase_of_a_key_file_commands_a_signed_vehicle(
        tmp_path: object) -> None:
    """A key file is SHA-256(passphrase) in hex: MAVProxy's `signing key PASSPHRASE`
    then speaks to a simulator signing with that file's key; before it, it cannot."""
    passphrase = "wildfire-ops-2026"
    key = hashlib.sha256(passphrase.encode()).digest()
    port = free_udp_port()
    uav = SimUav(f"udpout:127.0.0.1:{port}", speedup=10, signing_key=key)
    gcs = MavProxy(f"udpin:127.0.0.1:{port}", str(tmp_path))
    uav.start()
    try:
        wait_until(lambda: gcs.said("STABILIZE>"), timeout=60, message="MAVProxy sees it")
        gcs.type("mode GUIDED")                    # unsigned: refused by the vehicle
        wait_until(lambda: uav.refused()["unsigned"] > 0, timeout=20,
                   message="the unsigned command refused")
        assert uav.snapshot().mode == "STABILIZE"
        gcs.type("module load signing")
        gcs.type(f"signing key {passphrase}")
        wait_until(lambda: gcs.said("Setup signing key"), timeout=20,
                   message="MAVProxy signs")
        gcs.type("mode GUIDED")
        wait_until(lambda: uav.snapshot().mode == "GUIDED", timeout=30,
                   message="the signed command obeyed")
    finally:
        gcs.close()
        uav.stop()
