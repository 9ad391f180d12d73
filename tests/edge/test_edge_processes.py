"""The edge components as real OS processes (component_main), with the embedded broker.

No `[broker] url` in the fixture project: the broker component serves on a free loopback
port and the others find it through the run folder. Killing the broker and starting a
new incarnation keeps the URL, and the events manager reconnects by itself.
"""

from __future__ import annotations

import shutil
import signal
import subprocess
import sys
import tempfile
import threading
from collections.abc import Iterator
from pathlib import Path

import pytest

from mrss.actors.worldmodel.service import URL_FILE
from mrss.bus import BusEndpoints, ProxyThread, Publisher, Subscriber
from mrss.config.broker import BROKER_URL_FILE
from mrss.config.kinds import KINDS, ComponentKind
from mrss.edge.mqtt_client import MqttClient, MqttSettings
from mrss.messages import Envelope, Percept
from mrss.runtime.busport import ZmqBusPort
from mrss.runtime.component import ComponentContext
from mrss.runtime.datalayer_client import DataLayerClient
from mrss.testing import wait_until
from tests.edge.fixture_project import PROJECT_FIXTURE

COMPONENTS = {
    "broker": KINDS[ComponentKind.BROKER].target,
    "worldmodel": KINDS[ComponentKind.WORLDMODEL].target,
    "datalayer": KINDS[ComponentKind.DATALAYER].target,
    "events": KINDS[ComponentKind.EVENTS].target,
}


class Processes:
    def __init__(self, run_dir: Path, endpoints: BusEndpoints) -> None:
        self.run_dir = run_dir
        self.endpoints = endpoints
        self.procs: dict[str, subprocess.Popen[bytes]] = {}
        self.incarnations: dict[str, int] = {}

    def start(self, name: str) -> None:
        inc = self.incarnations.get(name, 0) + 1
        self.incarnations[name] = inc
        ctx = ComponentContext(name=name, incarnation=inc, project_dir=PROJECT_FIXTURE,
                               run_dir=self.run_dir, bus=self.endpoints.to_dict())
        log = open(self.run_dir / f"{name}.{inc}.log", "wb")  # noqa: SIM115 (kept by Popen)
        self.procs[name] = subprocess.Popen(
            [sys.executable, "-m", "mrss.runtime.main", COMPONENTS[name],
             "--name", name, "--inc", str(inc), "--context", ctx.to_json()],
            stdout=log, stderr=subprocess.STDOUT)
        log.close()

    def kill(self, name: str) -> None:
        proc = self.procs.pop(name)
        proc.kill()
        proc.wait(timeout=10)

    def stop_all(self) -> dict[str, int | None]:
        codes: dict[str, int | None] = {}
        for name in reversed(list(self.procs)):
            proc = self.procs[name]
            proc.send_signal(signal.SIGTERM)
            try:
                codes[name] = proc.wait(timeout=10)
            except subprocess.TimeoutExpired:
                proc.kill()
                proc.wait()
                codes[name] = None
        self.procs.clear()
        return codes

    def logs(self) -> str:
        return "\n".join(f"--- {p.name}\n{p.read_text(errors='replace')[-2000:]}"
                         for p in sorted(self.run_dir.glob("*.log")))


@pytest.fixture()
def processes() -> Iterator[Processes]:
    run_dir = Path(tempfile.mkdtemp(prefix="mrss-edgep-"))
    endpoints = BusEndpoints.ipc(run_dir)
    procs = Processes(run_dir, endpoints)
    try:
        with ProxyThread(endpoints):
            yield procs
            codes = procs.stop_all()
            assert all(code == 0 for code in codes.values()), (codes, procs.logs())
    finally:
        procs.stop_all()
        shutil.rmtree(run_dir, ignore_errors=True)


@pytest.mark.slow
def test_edge_processes_with_embedded_broker_survive_a_broker_kill(
        processes: Processes) -> None:
    percepts: list[str] = []
    lock = threading.Lock()

    def on_percept(env: Envelope) -> None:
        if isinstance(env.body, Percept):
            with lock:
                percepts.append(env.body.literal)

    sub = Subscriber(processes.endpoints, prefixes=["percept"])
    sub.start(on_percept)
    publisher = Publisher(processes.endpoints, src="test")
    port = ZmqBusPort(processes.endpoints, publisher, "test")
    client = DataLayerClient(port)
    sender: MqttClient | None = None
    try:
        processes.start("broker")
        url_file = processes.run_dir / BROKER_URL_FILE
        wait_until(url_file.is_file, timeout=30, message=f"broker URL\n{processes.logs()}")
        url = url_file.read_text().strip()
        assert url.startswith("mqtt://127.0.0.1:")
        for name in ("worldmodel", "datalayer", "events"):
            processes.start(name)
        wait_until(lambda: (processes.run_dir / URL_FILE).is_file(), timeout=30,
                   message=f"world model HTTP\n{processes.logs()}")
        wait_until(lambda: client.request("ground", ["lake"], timeout=0.5).ok, timeout=30,
                   message=f"grounding through two processes\n{processes.logs()}")

        sender = MqttClient(MqttSettings.from_config({"url": url, "reconnect_min": 0.1,
                                                      "reconnect_max": 0.5}))
        sender.start()
        assert sender.wait_connected(20)

        def delivered(area: str) -> bool:
            sender.publish("fixture/area", f'{{"area": "{area}", "priority": 1}}'.encode())
            with lock:
                return f"area_goal_received({area},1)" in percepts
        wait_until(lambda: delivered("a1"), timeout=30, interval=0.3,
                   message=f"MQTT -> percept\n{processes.logs()}")

        written = url_file.stat().st_ino
        processes.kill("broker")
        processes.start("broker")  # incarnation 2: same URL from the run folder
        # its start is over when it writes the URL file again (a new file, replaced in):
        # only then is it the one serving, and ready for the SIGTERM of the teardown
        wait_until(lambda: url_file.is_file() and url_file.stat().st_ino != written,
                   timeout=40, message=f"broker incarnation 2 started\n{processes.logs()}")
        wait_until(lambda: delivered("a2"), timeout=40, interval=0.3,
                   message=f"MQTT -> percept after broker restart\n{processes.logs()}")
        assert url_file.read_text().strip() == url
    finally:
        if sender is not None:
            sender.stop()
        port.close()
        sub.close()
        publisher.close()
