"""`mrss sim fleet`: robots of one process speak the real protocols, each on its own socket."""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path
from typing import Any

from mrss.links.geo import distance_m, offset
from mrss.links.mavlink import MavlinkLink
from mrss.links.mqtt import MqttLink
from mrss.testing import BrokerInfo, wait_until


def _threads(pid: int) -> int:
    for line in Path(f"/proc/{pid}/status").read_text().splitlines():
        if line.startswith("Threads:"):
            return int(line.split()[1])
    raise AssertionError("no thread count")


def test_fleet_of_two_uavs_and_two_ugvs_in_one_single_threaded_process(
        tmp_path: Path, mqtt_broker: BrokerInfo) -> None:
    proc = subprocess.Popen(
        [sys.executable, "-m", "mrss", "sim", "fleet", "--uav", "2", "--ugv", "2",
         "--broker", mqtt_broker.url, "--rate", "5", "--speedup", "20",
         "--run-dir", str(tmp_path)], stdout=subprocess.PIPE, stderr=subprocess.DEVNULL,
        text=True)
    links: list[Any] = []
    try:
        assert proc.stdout is not None
        addresses = dict(proc.stdout.readline().split() for _ in range(2))
        assert set(addresses) == {"uav1", "uav2"}
        # The address files the RCL's links read, as `mrss sim uav`'s component writes.
        wait_until(lambda: (tmp_path / "uav2.mavlink").is_file(), timeout=20,
                   message="address files")
        assert (tmp_path / "uav2.mavlink").read_text().strip() == addresses["uav2"]
        uavs = {r: MavlinkLink(r, url) for r, url in addresses.items()}
        ugvs = {r: MqttLink(r, mqtt_broker.url) for r in ("ugv1", "ugv2")}
        positions: dict[str, list[dict[str, Any]]] = {r: [] for r in [*uavs, *ugvs]}
        for robot, link in [*uavs.items(), *ugvs.items()]:
            link.add_telemetry_callback(
                lambda rec, robot=robot: rec["type"] == "position" and
                positions[robot].append(rec))
            link.start()
            links.append(link)
        for link in links:
            link.wait_up(timeout=20)
        # Every robot streams its own position (the UAVs at distinct homes).
        wait_until(lambda: all(len(p) >= 5 for p in positions.values()), timeout=20,
                   message="five positions from every robot")
        homes = [(p[-1]["lat"], p[-1]["lon"]) for p in positions.values()]
        assert len({(round(a, 6), round(b, 6)) for a, b in homes}) == 4
        # Commands work on each protocol: the UAV arms in GUIDED, the UGV drives.
        uavs["uav2"].set_mode("GUIDED")
        uavs["uav2"].arm()
        wait_until(lambda: uavs["uav2"].armed, timeout=10, message="uav2 armed")
        assert not uavs["uav1"].armed  # its own vehicle, not the fleet's
        start = positions["ugv1"][-1]
        target = offset(start["lat"], start["lon"], 20.0, 0.0)
        assert ugvs["ugv1"].goto(*target).status == "done"
        wait_until(lambda: distance_m(*target, positions["ugv1"][-1]["lat"],
                                      positions["ugv1"][-1]["lon"]) < 3.0,
                   timeout=20, message="ugv1 at its target")
        # One event loop serves all four robots: no thread per robot.
        assert _threads(proc.pid) <= 2
        assert proc.poll() is None
    finally:
        for link in links:
            link.close()
        proc.terminate()
        proc.wait(timeout=10)
    assert proc.returncode == 0
