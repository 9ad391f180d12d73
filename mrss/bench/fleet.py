"""`mrss bench fleet`: the whole system with N simulated robots at 5 Hz telemetry.

Per fleet size N (half UAVs over MAVLink/UDP, half UGVs over MQTT on a private
Mosquitto, all in one `mrss sim fleet` process), `mrss supervise` runs a generated
project (`mrss.bench.fleet_project`): bus, world model, data layer, the fleet, the RCL
with a real link per robot and the reasoner. Once every robot is available the bench
assigns each robot a goal every 10 s (a percept `assign(R, Seq)`, spread evenly over the
10 s) and, for the measured window, reports:

* percept -> skill start p50/p99: CLOCK_MONOTONIC at the skill's `start()` minus the
  same clock just before the bench published the percept;
* telemetry -> world model lag p50/p99: from the link's reception of a telemetry record
  in the RCL (the record's `ts`) to the world model's reply to its write (seen on the bus;
  the data layer sends telemetry writes in batches, `wm.upsert_many`, answered together
  after their commit);
* CPU (% of one core over the window) and RSS per component process;
* messages per second per topic (robot ids folded), as a bus observer sees them;
* lost: assignments without a skill start, telemetry records on the bus that never
  reached the world model, and messages the bench's subscriber dropped.
"""

from __future__ import annotations

import os
import re
import threading
import time
from collections import Counter
from contextlib import ExitStack
from dataclasses import dataclass, field

import psutil

from mrss.bench import fleet_project
from mrss.bench.harness import SupervisedProject
from mrss.bench.report import BenchReport
from mrss.bench.restart import percentile
from mrss.messages import (
    ActionStatus,
    Command,
    DataReply,
    DataRequest,
    Envelope,
    MindSnapshot,
    Percept,
    RobotData,
)
from mrss.runtime.forkserver import COMPONENT_COMM_PREFIX
from mrss.testing import find_mosquitto, mosquitto_broker
from mrss.world.topics import WM_REPLY_TOPIC, WM_REQUEST_TOPIC

RATE_HZ = 5.0
ASSIGN_EVERY_S = 10.0
_ROBOT_ID = re.compile(r"\b(uav|ugv)\d+\b")


@dataclass
class Sample:
    """What one fleet size measured."""

    robots: int
    window_s: float = 0.0
    e2e_ms: list[float] = field(default_factory=list)
    lag_ms: list[float] = field(default_factory=list)
    assigned: int = 0
    telemetry: int = 0
    written: int = 0
    bus_dropped: int = 0
    batches: list[int] = field(default_factory=list)
    topics: Counter[str] = field(default_factory=Counter)
    cpu: dict[str, float] = field(default_factory=dict)
    rss_mb: dict[str, float] = field(default_factory=dict)
    threads: dict[str, int] = field(default_factory=dict)

    @property
    def lost_assignments(self) -> int:
        return self.assigned - len(self.e2e_ms)

    @property
    def lost_telemetry(self) -> int:
        return self.telemetry - self.written


class FleetRun:
    """One supervised system with `robots` simulated robots, observed from the bus."""

    def __init__(self, robots: int, broker_url: str | None) -> None:
        uavs = robots // 2
        self.robot_ids = [f"uav{k}" for k in range(1, uavs + 1)] + \
            [f"ugv{k}" for k in range(1, robots - uavs + 1)]
        self._cond = threading.Condition()
        self._data = threading.Lock()  # records and written
        self.available: set[str] = set()  # robots whose telemetry reached the bus
        self.minds = 0
        self.measuring = False
        self.starts: dict[int, int] = {}
        self.records: dict[tuple[str, float], float] = {}  # (robot, ts) -> seen on the bus
        self.written: dict[tuple[str, float], float] = {}  # (robot, ts) -> written, time.time
        self.requests: dict[str, list[tuple[str, float]]] = {}  # write -> [(robot, ts)]
        self.batches: list[int] = []  # objects per world model write request
        self.topics: Counter[str] = Counter()
        files = {"project.toml": fleet_project.toml(uavs, robots - uavs, broker_url, RATE_HZ),
                 "agent.asl": fleet_project.AGENT, "rcl.py": fleet_project.RCL,
                 "datalayer.py": fleet_project.DATALAYER}
        self.system = SupervisedProject(fleet_project.PROJECT, files, prefixes=[""],
                                        on_message=self._on, tmp_prefix="mrss-bench-fleet-")

    def _on(self, env: Envelope) -> None:
        body, now = env.body, time.time()
        if self.measuring:
            self.topics[_ROBOT_ID.sub(r"\1<k>", env.topic)] += 1
        if isinstance(body, RobotData):
            if body.robot not in self.available:
                with self._cond:
                    self.available.add(body.robot)  # its link is up: telemetry flows
                    self._cond.notify_all()
            ts = body.data.get("ts")
            if self.measuring and isinstance(ts, float):
                with self._data:
                    self.records[(body.robot, ts)] = now
        elif isinstance(body, DataRequest) and env.topic == WM_REQUEST_TOPIC and body.args:
            objs = [body.args[0]] if body.function == "wm.upsert" else \
                body.args[0] if body.function == "wm.upsert_many" else []
            keys = [(str(obj.get("id")), ts) for obj in objs
                    if isinstance(obj, dict) and obj.get("kind") == "robot"
                    and isinstance(ts := (obj.get("attributes") or {}).get("ts"), float)]
            if keys:
                with self._data:
                    self.requests[body.request_id] = keys
                    self.batches.append(len(objs))
        elif isinstance(body, DataReply) and env.topic.startswith(WM_REPLY_TOPIC) and body.ok:
            with self._data:
                for key in self.requests.pop(body.request_id, []):
                    self.written[key] = now  # a batch is answered after its commit
        elif isinstance(body, ActionStatus):
            seq, t = body.progress.get("seq"), body.progress.get("t")
            if isinstance(seq, int) and isinstance(t, int):
                with self._cond:
                    self.starts[seq] = t
                    self._cond.notify_all()
        elif isinstance(body, MindSnapshot):
            with self._cond:
                self.minds += 1
                self._cond.notify_all()

    def wait_ready(self, timeout: float) -> None:
        """Until the reasoner answers and every robot is available."""
        deadline = time.monotonic() + timeout
        proc = self.system.proc
        while time.monotonic() < deadline:
            if proc.poll() is not None:
                tail = self.system.log_path.read_text(errors="replace").splitlines()[-15:]
                raise RuntimeError(f"mrss supervise exited {proc.returncode}; the end of its "
                                   "log:\n" + "\n".join(tail))
            self.system.pub.publish(Command(command="mind"))
            with self._cond:
                if self._cond.wait_for(lambda: self.minds > 0 and
                                       self.available >= set(self.robot_ids), timeout=0.5):
                    return
        missing = sorted(set(self.robot_ids) - self.available)
        raise TimeoutError(f"not ready after {timeout:.0f}s: reasoner answered {self.minds} "
                           f"times; robots not available: {missing[:10]}")

    def measure(self, seconds: float) -> Sample:
        """Assign goals for `seconds`, then let the system settle; the sample."""
        sample = Sample(robots=len(self.robot_ids))
        procs = _components(self.system.proc.pid)
        procs["bench"] = psutil.Process()  # this process: goals out, the whole bus in
        for child in procs["bench"].children():
            try:
                if child.name() == "mosquitto":
                    procs["mosquitto"] = child  # the UGVs' broker
            except psutil.Error:
                continue
        cpu0 = {name: _cpu(p) for name, p in procs.items()}
        sent: dict[int, int] = {}
        gap_ns = int(ASSIGN_EVERY_S / len(self.robot_ids) * 1e9)
        self.measuring = True
        begin = time.monotonic_ns()
        seq = 0
        while (now := time.monotonic_ns()) - begin < seconds * 1e9:
            due = begin + seq * gap_ns
            if due > now:
                time.sleep((due - now) / 1e9)
            robot = self.robot_ids[seq % len(self.robot_ids)]
            sent[seq] = time.monotonic_ns()
            self.system.pub.publish(Percept(literal=f"assign({robot}, {seq})"))
            seq += 1
        self.measuring = False
        sample.window_s = (time.monotonic_ns() - begin) / 1e9
        for name, p in procs.items():
            try:
                sample.cpu[name] = 100 * (_cpu(p) - cpu0[name]) / sample.window_s
                sample.rss_mb[name] = p.memory_info().rss / 2**20
                sample.threads[name] = p.num_threads()
            except psutil.Error:
                continue
        with self._cond:
            self._cond.wait_for(lambda: all(s in self.starts for s in sent), timeout=15)
            starts = dict(self.starts)
        deadline = time.monotonic() + 10
        while time.monotonic() < deadline:
            with self._data:
                records, written = dict(self.records), dict(self.written)
            if records.keys() <= written.keys():
                break
            time.sleep(0.2)  # the bench waits for the system's backlog, not a condition
        sample.assigned = len(sent)
        sample.e2e_ms = [(starts[s] - sent[s]) / 1e6 for s in sent if s in starts]
        sample.telemetry = len(records)
        sample.written = sum(1 for key in records if key in written)
        sample.lag_ms = [(written[key] - key[1]) * 1e3 for key in records if key in written]
        sample.topics = Counter({t: n for t, n in self.topics.items()})
        sample.bus_dropped = self.system.sub.dropped
        with self._data:
            sample.batches = list(self.batches)
        return sample

    def close(self) -> None:
        self.system.close()


def _components(root: int) -> dict[str, psutil.Process]:
    """The component processes under `mrss supervise` (by their process name), plus it."""
    found = {"supervisor": psutil.Process(root)}
    for child in found["supervisor"].children(recursive=True):
        try:
            name = child.name()
        except psutil.Error:
            continue
        if name.startswith(COMPONENT_COMM_PREFIX):
            found[name[len(COMPONENT_COMM_PREFIX):]] = child
    return found


def _cpu(p: psutil.Process) -> float:
    times = p.cpu_times()
    return float(times.user + times.system)


def run(quick: bool, sizes: list[int] | None = None) -> BenchReport:
    """The fleet bench at `sizes` robots (default: 10 with `quick`, else 10 to 200)."""
    sizes = sizes or ([10] if quick else [10, 50, 100, 200])
    window = 2.0 if quick else 25.0
    report = BenchReport(
        "fleet", ["robots", "assignments", "e2e p50 ms", "e2e p99 ms", "telemetry",
                  "lag p50 ms", "lag p99 ms", "lost", "busiest component (CPU %, RSS MB)",
                  "msgs/s"], quick=quick)
    binary = find_mosquitto()
    if binary is None:
        report.notes.append("mosquitto not found: the UGVs use the embedded broker (amqtt)")
    samples: list[Sample] = []
    for robots in sizes:
        load = os.getloadavg()[0]
        with ExitStack() as stack:
            url = stack.enter_context(mosquitto_broker(binary)).url if binary else None
            fleet = FleetRun(robots, url)
            stack.callback(fleet.close)
            fleet.wait_ready(timeout=60 + robots)
            sample = fleet.measure(window)
        samples.append(sample)
        _row(report, sample)
        report.notes.append(f"N={robots}: load average {load:.2f} before, "
                            f"{os.getloadavg()[0]:.2f} after")
    for sample in samples:
        report.notes.append(f"N={sample.robots} CPU % of one core / RSS MB / threads: "
                            + ", ".join(
            f"{name} {sample.cpu[name]:.0f}/{sample.rss_mb[name]:.0f}/"
            f"{sample.threads.get(name, 0)}"
            for name in sorted(sample.cpu, key=lambda n: -sample.cpu[n])))
        if sample.batches:
            report.notes.append(
                f"N={sample.robots} world model writes per request: mean "
                f"{sum(sample.batches) / len(sample.batches):.1f}, p99 "
                f"{percentile([float(b) for b in sample.batches], 99):.0f}")
        report.notes.append(f"N={sample.robots} msgs/s by topic: " + ", ".join(
            f"{topic} {count / sample.window_s:.0f}"
            for topic, count in sample.topics.most_common(8)))
    target = next((s for s in samples if s.robots == 100), None)
    if target is not None:
        report.check("100 robots at 5 Hz: e2e p99 <= 20 ms",
                     bool(target.e2e_ms) and percentile(target.e2e_ms, 99) <= 20.0)
        report.check("100 robots at 5 Hz: telemetry -> world model lag p99 <= 200 ms",
                     bool(target.lag_ms) and percentile(target.lag_ms, 99) <= 200.0)
        report.check("100 robots at 5 Hz: nothing lost",
                     target.lost_assignments == 0 and target.lost_telemetry == 0
                     and target.bus_dropped == 0)
    report.notes.append(
        "e2e: bench percept -> proxy -> reasoner -> reliable channel -> RCL -> skill start(); "
        "lag: telemetry record received by the RCL's link -> data layer -> world model "
        "write answered. Robots: half UAVs (MAVLink/UDP), half UGVs (MQTT: Mosquitto, else "
        "the embedded broker), one "
        f"`mrss sim fleet` process; each robot gets a goal every {ASSIGN_EVERY_S:g} s. "
        f"Scheduling: bus, rcl, reasoner `{fleet_project.FAVOURED}`, data layer and world "
        f"model `{fleet_project.TELEMETRY}`, the fleet and the bench ordinary. The machine "
        f"({os.cpu_count()} CPUs) is shared: the numbers are noisy.")
    return report


def _row(report: BenchReport, s: Sample) -> None:
    system = [name for name in s.cpu if name not in ("bench", "mosquitto")]
    busiest = max(system, key=lambda n: s.cpu[n]) if system else None
    report.add_row(
        s.robots, s.assigned,
        percentile(s.e2e_ms, 50) if s.e2e_ms else None,
        percentile(s.e2e_ms, 99) if s.e2e_ms else None,
        s.telemetry,
        percentile(s.lag_ms, 50) if s.lag_ms else None,
        percentile(s.lag_ms, 99) if s.lag_ms else None,
        f"{s.lost_assignments} assignments, {s.lost_telemetry} records, {s.bus_dropped} bus",
        f"{busiest} ({s.cpu[busiest]:.0f} %, {s.rss_mb[busiest]:.0f})" if busiest else None,
        sum(s.topics.values()) / s.window_s if s.window_s else None)
