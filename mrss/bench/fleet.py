"""`mrss bench fleet`: the whole system with N simulated robots at 5 Hz telemetry.

Per fleet size N (half UAVs over MAVLink/UDP, half UGVs over MQTT on a private
Mosquitto, all in one `mrss sim fleet` process), `mrss supervise` runs a generated
project (`mrss.bench.fleet_project`): bus, world model, data layer, the fleet, the RCL
with a real link per robot and the reasoner. Once every robot is available the bench
sends as many goals every 10 s as there are robots (spread evenly over the 10 s), each
addressed to a role, as many to `uav` as there are UAVs and to `ugv` as UGVs (a percept
`assign(Kind, Seq)`: the agent's `goto(any([Kind]), Seq)`, awarded by the RCL's
allocation to a free robot of that kind). Each size runs twice, at the shipped
defaults (no scheduling keys) and tuned (the opt-in realtime of
`fleet_project.Scheduling.TUNED`), each for `WINDOWS` windows one after the other
(`mrss.bench.fleet_table`: worst window, share meeting the targets). For each window it
measures:

* percept -> skill start p50/p99: CLOCK_MONOTONIC at the skill's `start()` minus the
  same clock just before the bench published the percept (the allocation's award
  included);
* telemetry -> world model lag p50/p99: from the link's reception of a telemetry record
  in the RCL (the record's `ts`) to the world model's reply to its write (seen on the bus;
  the data layer sends telemetry writes in batches, `wm.upsert_many`, answered together
  after their commit);
* CPU (% of one core over the window) and RSS per component process;
* messages per second per topic (robot ids folded), as a bus observer sees them;
* lost: assignments without a skill start, telemetry records on the bus that never
  reached the world model (both within LATE_AFTER_S: later is late, and counts as late
  in the percentiles), and messages the bench's subscriber dropped.
"""

from __future__ import annotations

import os
import re
import threading
import time
from collections import Counter
from contextlib import ExitStack

import psutil

from mrss.bench import fleet_project, fleet_table
from mrss.bench.fleet_project import Scheduling
from mrss.bench.fleet_table import Sample
from mrss.bench.harness import SupervisedProject
from mrss.bench.report import BenchReport
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

SIZES = (10, 50, 100, 200, 400)  # robots, the full run's rows
WINDOWS = 5  # per size and scheduling: the N = 100 result is bimodal (docs/e2e.md)
WINDOW_S = 10.0  # each robot is assigned one goal per window
RATE_HZ = 5.0
ASSIGN_EVERY_S = 10.0
LATE_AFTER_S = 15.0  # a skill start or a write not seen this long after its window: late
_ROBOT_ID = re.compile(r"\b(uav|ugv)\d+\b")


class FleetRun:
    """One supervised system with `robots` simulated robots, observed from the bus."""

    def __init__(self, robots: int, broker_url: str | None,
                 scheduling: Scheduling = Scheduling.TUNED) -> None:
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
        self.next_seq = 0  # assignments are numbered across the windows
        files = {"project.toml": fleet_project.toml(uavs, robots - uavs, broker_url, RATE_HZ,
                                                    scheduling),
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
        """One window: assign goals for `seconds`, then let the system settle (up to
        LATE_AFTER_S for the skill starts, LATE_AFTER_S for the writes); the sample. What
        has not come by then is late: lost, and counted as late in the percentiles."""
        sample = Sample(robots=len(self.robot_ids))
        with self._data:
            self.records.clear()
            self.written.clear()
            self.requests.clear()
            self.batches.clear()
            self.topics.clear()
        dropped0 = self.system.sub.dropped
        procs = components(self.system.proc.pid)
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
        first = seq = self.next_seq
        while (now := time.monotonic_ns()) - begin < seconds * 1e9:
            due = begin + (seq - first) * gap_ns
            if due > now:
                time.sleep((due - now) / 1e9)
            kind = self.robot_ids[seq % len(self.robot_ids)][:3]  # uav | ugv: the role
            sent[seq] = time.monotonic_ns()
            self.system.pub.publish(Percept(literal=f"assign({kind}, {seq})"))
            seq += 1
        self.measuring = False
        self.next_seq = seq
        sample.window_s = (time.monotonic_ns() - begin) / 1e9
        for name, p in procs.items():
            try:
                sample.cpu[name] = 100 * (_cpu(p) - cpu0[name]) / sample.window_s
                sample.rss_mb[name] = p.memory_info().rss / 2**20
                sample.threads[name] = p.num_threads()
            except psutil.Error:
                continue
        with self._cond:
            self._cond.wait_for(lambda: all(s in self.starts for s in sent),
                                timeout=LATE_AFTER_S)
            starts = dict(self.starts)
        deadline = time.monotonic() + LATE_AFTER_S
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
        sample.bus_dropped = self.system.sub.dropped - dropped0
        with self._data:
            sample.batches = list(self.batches)
        return sample

    def close(self) -> None:
        self.system.close()


def components(root: int) -> dict[str, psutil.Process]:
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
    """The fleet bench at `sizes` robots (default: 10 with `quick`, else 10 to 400): per
    size, a system at the shipped defaults, then one tuned, `WINDOWS` windows each."""
    sizes = sizes or ([10] if quick else list(SIZES))
    window, windows = (2.0, 2) if quick else (WINDOW_S, WINDOWS)
    report = BenchReport("fleet", fleet_table.COLUMNS, quick=quick)
    binary = find_mosquitto()
    if binary is None:
        report.notes.append("mosquitto not found: the UGVs use the embedded broker (amqtt)")
    rows: list[fleet_table.Windows] = []
    for robots in sizes:
        for scheduling in (Scheduling.DEFAULTS, Scheduling.TUNED):
            load = os.getloadavg()[0]
            row = fleet_table.Windows(robots, scheduling)
            with ExitStack() as stack:
                url = stack.enter_context(mosquitto_broker(binary)).url if binary else None
                fleet = FleetRun(robots, url, scheduling)
                stack.callback(fleet.close)
                fleet.wait_ready(timeout=60 + robots)
                for _ in range(windows):
                    row.samples.append(fleet.measure(window))
            row.load = (load, os.getloadavg()[0])
            rows.append(row)
            fleet_table.add(report, row)
    fleet_table.targets(report, rows)
    for row in rows:
        fleet_table.notes(report, row)
    report.notes.append(
        "e2e: bench percept -> proxy -> reasoner -> reliable channel -> RCL -> skill start(); "
        "lag: telemetry record received by the RCL's link -> data layer -> world model "
        "write answered. Robots: half UAVs (MAVLink/UDP), half UGVs (MQTT: Mosquitto, else "
        "the embedded broker), one "
        f"`mrss sim fleet` process; one goal per robot every {ASSIGN_EVERY_S:g} s, each "
        "addressed to a role (any uav, any ugv) and awarded by the RCL's allocation. "
        f"{windows} windows of {window:g} s per row, one after the other on one system; p50 "
        "over all windows, p99 of the worst window and how many windows met the target. "
        f"A skill start or write not seen {LATE_AFTER_S:g} s after its window is late: "
        "lost, and ranked above every sample in the percentiles ('late' when the p99 falls "
        "on one). Scheduling: 'shipped defaults' sets nothing (every component at nice 0, "
        f"SCHED_OTHER); 'tuned (opt-in)' sets bus, rcl, reasoner `{fleet_project.FAVOURED}` "
        f"and data layer, world model `{fleet_project.TELEMETRY}` as docs/config.md advises "
        "(no shipped project does); the fleet and the bench ordinary in both. Targets are "
        "judged on the tuned rows, as the performance issue set them. The machine "
        f"({os.cpu_count()} CPUs) is shared: the numbers are noisy.")
    return report
