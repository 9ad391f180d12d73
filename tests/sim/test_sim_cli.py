"""`mrss sim uav|ugv`: argument errors, clean stops on SIGTERM."""

from __future__ import annotations

import signal
import subprocess
import sys

from mrss.links.mavconn import MavConnection
from mrss.links.mqtt_probe import MqttProbe as Probe
from mrss.links.ugv_protocol import UgvTopics
from mrss.testing import BrokerInfo, free_udp_port, wait_until


def run_cli(*args: str) -> subprocess.CompletedProcess[str]:
    return subprocess.run([sys.executable, "-m", "mrss", "sim", *args], capture_output=True,
                          text=True, timeout=60)


def test_bad_arguments_exit_2_with_a_clear_message() -> None:
    out = run_cli("uav", "--home=north,pole")
    assert out.returncode == 2 and "could not convert" in out.stderr
    out = run_cli("uav", "--hotspots=95,10")
    assert out.returncode == 2 and "out of range" in out.stderr
    out = run_cli("uav", "--speedup", "0")
    assert out.returncode == 2 and "speedup must be positive" in out.stderr
    out = run_cli("uav", "--signing-key", "/nonexistent/uav.key")
    assert out.returncode == 2 and "key '--signing-key': cannot read signing key file" \
        in out.stderr and "Traceback" not in out.stderr
    out = run_cli("ugv", "--broker", "http://127.0.0.1:1")
    assert out.returncode == 2 and "mqtt://" in out.stderr
    out = run_cli()
    assert out.returncode == 2 and "uav" in out.stderr


def test_uav_process_serves_until_sigterm() -> None:
    port = free_udp_port()
    gcs = MavConnection(f"udpin:127.0.0.1:{port}", source_system=255, source_component=190)
    proc = subprocess.Popen([sys.executable, "-m", "mrss.sim.uav", "--out",
                             f"udpout:127.0.0.1:{port}", "--sysid", "3"],
                            stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
    try:
        def heartbeat_from_3() -> bool:
            msg = gcs.recv(timeout=0.2)
            return msg is not None and msg.get_type() == "HEARTBEAT" \
                and msg.get_srcSystem() == 3
        wait_until(heartbeat_from_3, timeout=20, message="heartbeat of system 3")
        proc.send_signal(signal.SIGTERM)
        assert proc.wait(timeout=10) == 0
    finally:
        if proc.poll() is None:
            proc.kill()
            proc.wait()
        gcs.close()


def test_ugv_process_says_online_then_offline_on_sigterm(mqtt_broker: BrokerInfo) -> None:
    topics = UgvTopics.for_robot("cli1", "test/cli")
    probe = Probe(mqtt_broker.host, mqtt_broker.port, [topics.status, topics.telemetry])
    proc = subprocess.Popen([sys.executable, "-m", "mrss", "sim", "ugv", "--broker",
                             mqtt_broker.url, "--id", "cli1", "--prefix", "test/cli"],
                            stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
    try:
        wait_until(lambda: probe.received(topics.telemetry), timeout=20, message="telemetry")
        assert probe.received(topics.status)[-1] == b"online"
        proc.send_signal(signal.SIGTERM)
        assert proc.wait(timeout=10) == 0
        wait_until(lambda: probe.received(topics.status)[-1] == b"offline", timeout=5,
                   message="offline on a clean stop")
    finally:
        if proc.poll() is None:
            proc.kill()
            proc.wait()
        probe.publish(topics.status, b"", retain=True)  # clear the retained status
        probe.close()
