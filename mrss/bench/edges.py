"""`mrss bench edges`: latency through the edge components on the real bus and broker.

Measures, in one process with the components on their own threads (proxy, embedded
amqtt broker, events manager, data layer, world model):
- a data layer call (`ping`) and a grounding (`ground`, data layer -> world model),
  request to reply over the bus;
- an MQTT message to the percept it becomes on the bus (events manager + adapter).
"""

from __future__ import annotations

import shutil
import statistics
import tempfile
import threading
import time
from pathlib import Path
from typing import Any

from mrss.actors.broker.service import EmbeddedBroker, resolve_broker
from mrss.actors.datalayer.service import DataLayerComponent
from mrss.actors.events.service import ExternalEventsManager
from mrss.actors.worldmodel.service import WorldModelComponent
from mrss.bench.report import BenchReport
from mrss.bus import BusEndpoints, ProxyThread, Subscriber
from mrss.config.broker import BROKER_URL_FILE
from mrss.edge.mqtt_client import MqttClient, MqttSettings
from mrss.messages import Envelope, Percept
from mrss.runtime.busport import ZmqBusPort
from mrss.runtime.component import ComponentContext
from mrss.runtime.datalayer_client import DataLayerClient

PROJECT_TOML = """
[worldmodel]
seed = "world.json"
http = false
"""
EVENTS_PY = """
from mrss.actors.events.adapter import ExternalAdapter
from mrss.edge.payloads import Field

class BenchAdapter(ExternalAdapter):
    def start(self):
        self.map_json("bench/area", "area_goal_received", Field("area", "atom"),
                      Field("seq", "int"))
"""
WORLD_JSON = '[{"id": "lake", "kind": "water_source", "position": {"lat": 43.6, "lon": 1.4}}]'


def _wait(cond: Any, timeout: float, what: str) -> None:
    deadline = time.monotonic() + timeout
    while not cond():
        if time.monotonic() > deadline:
            raise TimeoutError(f"bench: {what} did not happen within {timeout}s")
        time.sleep(0.01)


def _row(report: BenchReport, name: str, samples: list[float], elapsed: float) -> None:
    ms = sorted(s * 1000 for s in samples)
    p95 = ms[min(len(ms) - 1, int(len(ms) * 0.95))]
    report.add_row(name, len(ms), statistics.median(ms), p95, len(ms) / elapsed)


def _calls(client: DataLayerClient, function: str, args: list[Any], n: int,
           ) -> tuple[list[float], float]:
    samples = []
    start = time.perf_counter()
    for _ in range(n):
        t0 = time.perf_counter()
        client.call(function, args, timeout=5)
        samples.append(time.perf_counter() - t0)
    return samples, time.perf_counter() - start


class _PerceptTimes:
    """Arrival times of `area_goal_received(a, Seq)` percepts on the bus, by Seq."""

    def __init__(self, endpoints: BusEndpoints) -> None:
        self.arrived: dict[int, float] = {}
        self.changed = threading.Condition()
        self.sub = Subscriber(endpoints, prefixes=["percept"])
        self.sub.start(self._on)
        self.sub.wait_connected(10)

    def _on(self, env: Envelope) -> None:
        if isinstance(env.body, Percept) and env.body.literal.startswith("area_goal_received"):
            seq = int(env.body.literal.rstrip(")").rsplit(",", 1)[1])
            with self.changed:
                self.arrived[seq] = time.perf_counter()
                self.changed.notify_all()

    def wait_for(self, seqs: range, timeout: float) -> bool:
        with self.changed:
            return self.changed.wait_for(lambda: all(s in self.arrived for s in seqs), timeout)


def _mqtt_to_percept(url: str, endpoints: BusEndpoints, n: int,
                     ) -> tuple[tuple[list[float], float], tuple[list[float], float]]:
    """(one-at-a-time latencies, elapsed) and (burst latencies, elapsed)."""
    times = _PerceptTimes(endpoints)
    sender = MqttClient(MqttSettings.from_url(url), client_id="bench-sender")
    sender.start()

    def send(seq: int) -> float:
        t0 = time.perf_counter()
        sender.publish("bench/area", f'{{"area": "a", "seq": {seq}}}'.encode())
        return t0

    try:
        _wait(lambda: sender.wait_connected(0.1), 20, "MQTT sender connected")
        _wait(lambda: send(-1) and times.wait_for(range(-1, 0), 0.2), 20, "first percept")
        single: list[float] = []
        start = time.perf_counter()
        for seq in range(n // 4):
            t0 = send(seq)
            if times.wait_for(range(seq, seq + 1), 5):
                single.append(times.arrived[seq] - t0)
        single_elapsed = time.perf_counter() - start
        base = n
        sent = {}
        start = time.perf_counter()
        for seq in range(base, base + n):
            sent[seq] = send(seq)
        times.wait_for(range(base, base + n), 60)
        burst_elapsed = time.perf_counter() - start
        burst = [times.arrived[s] - sent[s] for s in sent if s in times.arrived]
        return (single, single_elapsed), (burst, burst_elapsed)
    finally:
        sender.stop()
        times.sub.close()


def run(quick: bool) -> BenchReport:
    """Measure the edge paths; `quick` uses small counts."""
    calls, messages = (200, 200) if quick else (2000, 2000)
    report = BenchReport("edges", ["path", "n", "p50 ms", "p95 ms", "per s"], quick=quick)
    tmp = Path(tempfile.mkdtemp(prefix="mrss-bench-edges-"))
    project, run_dir = tmp / "project", tmp / "run"
    project.mkdir()
    run_dir.mkdir()
    (project / "project.toml").write_text(PROJECT_TOML)
    (project / "events.py").write_text(EVENTS_PY)
    (project / "world.json").write_text(WORLD_JSON)
    endpoints = BusEndpoints.ipc(run_dir)
    started: list[Any] = []
    contexts: list[ComponentContext] = []
    try:
        with ProxyThread(endpoints):
            url, _ = resolve_broker({})
            broker = EmbeddedBroker()
            broker.serve_at(url)
            started.append(broker)
            (run_dir / BROKER_URL_FILE).write_text(url)
            for name, component in (("worldmodel", WorldModelComponent()),
                                    ("datalayer", DataLayerComponent()),
                                    ("events", ExternalEventsManager())):
                ctx = ComponentContext(name=name, incarnation=1, project_dir=project,
                                       run_dir=run_dir, bus=endpoints.to_dict())
                contexts.append(ctx)
                component.start(ctx)
                started.append(component)
            caller = ComponentContext(name="bench", incarnation=1, project_dir=project,
                                      run_dir=run_dir, bus=endpoints.to_dict())
            contexts.append(caller)
            port = ZmqBusPort(endpoints, caller.publisher, "bench")
            started.append(port)
            client = DataLayerClient(port)
            _wait(lambda: client.request("ground", ["lake"], timeout=0.5).ok, 20,
                  "grounding answered")
            samples, elapsed = _calls(client, "ping", [], calls)
            _row(report, "data layer call (ping)", samples, elapsed)
            samples, elapsed = _calls(client, "ground", ["lake"], calls)
            _row(report, "grounding via world model", samples, elapsed)
            (single, t_single), (burst, t_burst) = _mqtt_to_percept(url, endpoints, messages)
            _row(report, "MQTT message -> percept, one at a time", single, t_single)
            _row(report, f"MQTT -> percept, burst of {messages}", burst, t_burst)
            report.check("every MQTT message became a percept",
                         len(single) == messages // 4 and len(burst) == messages)
            report.notes.append("one process, components on threads; ipc bus, amqtt broker")
    finally:
        for each in reversed(started):
            each.stop() if hasattr(each, "stop") else each.close()
        for ctx in contexts:
            ctx.publisher.close()
        shutil.rmtree(tmp, ignore_errors=True)
    return report
