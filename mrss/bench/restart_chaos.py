"""Restarts under repeated faults: the shipped wildfire project, a random kill a second.

Issue 9 saw restarts take seconds under a chaos run (p99 ~5 s, the bus proxy and the
reasoner among the slowest). This runs `mrss supervise wildfire` as a real process
(simulators sped up), waits until every component runs (the root's `ctl.tree`
answers), then SIGKILLs a running component every 0.5-1.5 s, in seeded random rounds
(each component once per round, so every one of them is timed). A restart's
time is from the SIGKILL to the root's `start` line for the next incarnation in the
run's `mrss.log` (wall clock, ms), so the bus proxy's own restart is timed like the
others (its `sup.start` reaches the bus later, held until a subscriber is back).
"""

from __future__ import annotations

import datetime
import os
import random
import re
import shutil
import signal
import subprocess
import tempfile
import threading
import time
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from mrss.bus import BusEndpoints, Publisher, Subscriber
from mrss.config.projects import project_path
from mrss.interpreter import python_module
from mrss.logfile import read_history
from mrss.logs import log_file
from mrss.messages import Command, Envelope, SupEvent

_START = re.compile(r"^(\d{4}-\d\d-\d\d \d\d:\d\d:\d\d,\d{3}) \S+ INFO start (\S+) pid=\d+ "
                    r"inc=(\d+)")


@dataclass(frozen=True)
class Kill:
    child: str
    incarnation: int  # the killed one
    at: float  # time.time() of the SIGKILL


class _Tree:
    """The root's tree from its `ctl.tree` answers."""

    def __init__(self, endpoints: BusEndpoints) -> None:
        self._cond = threading.Condition()
        self._trees: list[dict[str, Any]] = []
        self.sub = Subscriber(endpoints, prefixes=["sup.tree"], name="bench-chaos")
        self.sub.start(self._on)
        self.pub = Publisher(endpoints, src="bench-chaos", batching=False)

    def _on(self, env: Envelope) -> None:
        if isinstance(env.body, SupEvent) and isinstance(env.body.detail.get("tree"), dict):
            with self._cond:
                self._trees.append(env.body.detail["tree"])
                self._cond.notify_all()

    def children(self, timeout: float = 10.0) -> dict[str, dict[str, Any]]:
        deadline = time.monotonic() + timeout
        with self._cond:
            seen = len(self._trees)
        while time.monotonic() < deadline:
            self.pub.publish(Command(command="tree"))
            with self._cond:
                if self._cond.wait_for(lambda: len(self._trees) > seen, 0.2):
                    return {c["id"]: c for c in self._trees[-1]["children"]}
        raise TimeoutError("no ctl.tree answer")

    def all_running(self, timeout: float) -> dict[str, dict[str, Any]]:
        deadline = time.monotonic() + timeout
        while time.monotonic() < deadline:
            try:
                kids = self.children()
            except TimeoutError:
                continue
            if kids and all(c["state"] == "running" for c in kids.values()):
                return kids
            time.sleep(0.2)
        raise TimeoutError("not every component came back")

    def close(self) -> None:
        self.sub.close()
        self.pub.close()


def chaos_restarts(kills: int, seed: int = 9, project: str = "wildfire",
                   projects: Path | None = None) -> dict[str, list[float]]:
    """Seconds from SIGKILL to the next incarnation's start, per component."""
    source = project_path(project, projects)
    tmp = Path(tempfile.mkdtemp(prefix="mrss-bench-chaos-"))
    run_dir = tmp / "run"
    run_dir.mkdir()
    env = {**os.environ, "MRSS_PROJECTS": str(source.parent), "MRSS_SIM_SPEEDUP": "20"}
    tree = _Tree(BusEndpoints.ipc(run_dir))
    rng = random.Random(seed)
    done: list[Kill] = []
    with (tmp / "supervise.log").open("w") as sink:
        proc = subprocess.Popen(
            python_module("mrss", "supervise", project, "--run-dir", str(run_dir),
                          "--no-tui"), env=env, stdout=sink, stderr=subprocess.STDOUT,
            start_new_session=True)
    try:
        tree.all_running(timeout=120)
        order: list[str] = []
        for _ in range(kills):
            running = {c: k for c, k in tree.children().items() if k["state"] == "running"}
            if not order:  # rounds: every component once per round, in a seeded order
                order = sorted(running)
                rng.shuffle(order)
            child = next((c for c in order if c in running), rng.choice(sorted(running)))
            if child in order:
                order.remove(child)
            done.append(Kill(child, running[child]["incarnation"], time.time()))
            os.kill(running[child]["pid"], signal.SIGKILL)
            time.sleep(rng.uniform(0.5, 1.5))  # the fault schedule
        tree.all_running(timeout=120)
        return _latencies(done, read_history(log_file(run_dir)))
    finally:
        tree.close()
        if proc.poll() is None:
            proc.send_signal(signal.SIGTERM)
            try:
                proc.wait(timeout=60)
            except subprocess.TimeoutExpired:
                os.killpg(proc.pid, signal.SIGKILL)
                proc.wait(timeout=10)
        shutil.rmtree(tmp, ignore_errors=True)


def _latencies(kills: list[Kill], log: str) -> dict[str, list[float]]:
    starts: dict[tuple[str, int], float] = {}
    for line in log.splitlines():
        m = _START.match(line)
        if m:
            at = datetime.datetime.strptime(m[1], "%Y-%m-%d %H:%M:%S,%f").timestamp()
            starts.setdefault((m[2], int(m[3])), at)
    out: dict[str, list[float]] = {}
    for k in kills:
        started = starts.get((k.child, k.incarnation + 1))
        if started is None:
            raise RuntimeError(f"no start of {k.child} incarnation {k.incarnation + 1} in the log")
        out.setdefault(k.child, []).append(max(0.0, started - k.at))
    return out
