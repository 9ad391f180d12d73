"""`mrss bench memory`: the shipped wildfire system's memory, and how long it takes to start.

`mrss supervise wildfire --no-tui` runs as a real process (a fresh run folder, the
project as shipped), six times (twice with `--quick`) with one user cache folder of its
own (seeded with the user's AgentSpeak parser tables): the first start checks the
project, the later ones find that check remembered (an unchanged project), and both are
reported. Its start is the time from just before the
command is started to the root's `start reasoner` line in the run's `mrss.log` (its own
ms clock): the root supervisor, the fork server's imports and project check (the first
start's), then every component in order,
each ready before the next, the reasoner last. Then, once the system has run for a few
seconds, the proportional set size (PSS, from /proc/PID/smaps_rollup: a page shared by n
processes counts 1/n in each, so the column adds up to what the system takes) of every
process of its tree, and its threads.

References measured in the same run: a bare interpreter (`python -P -c pass`) started and
waited for, and the PSS of one that sleeps. The targets are the performance issue's, for
this machine: the whole system within 150 MiB, started within 1.0 s.
"""

from __future__ import annotations

import datetime
import os
import re
import shutil
import signal
import statistics
import subprocess
import sys
import tempfile
import time
from dataclasses import dataclass, field
from pathlib import Path

import psutil

from mrss import usercache
from mrss.bench.report import BenchReport, Relation
from mrss.bench.soak_sampler import tree_processes
from mrss.config.projects import project_path
from mrss.interpreter import python_module
from mrss.logs import log_file

PROJECT = "wildfire"
LAST = "reasoner"  # the last component to start: the system runs once it did
TOTAL_MIB = 150.0
START_S = 1.0

_LINE = re.compile(r"^(\d{4}-\d\d-\d\d \d\d:\d\d:\d\d,\d{3}) \S+ INFO (.*)$")
_START = re.compile(r"start (\S+) pid=\d+ inc=1 startup_ms=([\d.]+)")


@dataclass
class Run:
    """One start of the system and its memory afterwards."""

    start_s: float
    pss_mib: dict[str, float] = field(default_factory=dict)  # process label -> PSS
    threads: dict[str, int] = field(default_factory=dict)
    root_up_s: float = 0.0  # command -> the root's first line ("supervising ...")
    first_start_s: float = 0.0  # command -> the first component's start line
    startup_ms: dict[str, float] = field(default_factory=dict)  # component -> its own start

    @property
    def total(self) -> float:
        return sum(self.pss_mib.values())


def pss_mib(pid: int) -> float:
    """A process's proportional set size in MiB (/proc/PID/smaps_rollup)."""
    with open(f"/proc/{pid}/smaps_rollup") as f:
        for line in f:
            if line.startswith("Pss:"):
                return int(line.split()[1]) / 1024
    raise ValueError(f"no Pss in /proc/{pid}/smaps_rollup")


def tree_memory(root: int) -> tuple[dict[str, float], dict[str, int]]:
    """PSS and threads of every process of `root`'s tree, named as `mrss bench soak`
    names them (supervisor, forkserver, the components, broker/mosquitto)."""
    pss: dict[str, float] = {}
    threads: dict[str, int] = {}
    for name, proc in tree_processes(psutil.Process(root)).items():
        try:
            pss[name] = pss_mib(proc.pid)
            threads[name] = proc.num_threads()
        except (psutil.Error, OSError, ValueError):
            continue  # gone meanwhile
    return pss, threads


def _stamp(text: str) -> float:
    return datetime.datetime.strptime(text, "%Y-%m-%d %H:%M:%S,%f").timestamp()


def _read_start(log: Path, began: float, run: Run) -> bool:
    """Fill `run`'s start figures from the log; True once the last component started."""
    try:
        text = log.read_text(errors="replace")
    except OSError:
        return False
    done = False
    for line in text.splitlines():
        m = _LINE.match(line)
        if not m:
            continue
        at, what = _stamp(m[1]) - began, m[2]
        if what.startswith("supervising ") and not run.root_up_s:
            run.root_up_s = at
        started = _START.match(what)
        if started and started[1] not in run.startup_ms:
            if not run.startup_ms:
                run.first_start_s = at
            run.startup_ms[started[1]] = float(started[2])
            if started[1] == LAST:
                run.start_s, done = at, True
    return done


def start_once(settle: float, cache: Path, timeout: float = 120.0) -> Run:
    """Start the system, time it to a running reasoner, measure its memory, stop it;
    `cache` is the user's cache folder it sees (where a clean check is remembered)."""
    source = project_path(PROJECT)
    tmp = Path(tempfile.mkdtemp(prefix="mrss-bench-memory-"))
    run_dir = tmp / "run"
    run_dir.mkdir()
    env = {**os.environ, "MRSS_PROJECTS": str(source.parent), "XDG_CACHE_HOME": str(cache)}
    argv = python_module("mrss", "supervise", PROJECT, "--run-dir", str(run_dir), "--no-tui")
    run = Run(start_s=float("inf"))
    with (tmp / "supervise.log").open("w") as sink:
        began = time.time()
        proc = subprocess.Popen(argv, env=env, stdout=sink, stderr=subprocess.STDOUT,
                                stdin=subprocess.DEVNULL, start_new_session=True)
    try:
        deadline = time.monotonic() + timeout
        while not _read_start(log_file(run_dir), began, run):
            if proc.poll() is not None or time.monotonic() > deadline:
                raise RuntimeError(f"mrss supervise {PROJECT} did not start its {LAST} "
                                   f"(exit {proc.poll()}); see {tmp / 'supervise.log'}")
            time.sleep(0.02)  # the figure is the log line's own time, not this poll's
        time.sleep(settle)  # memory once it runs, not while it starts
        run.pss_mib, run.threads = tree_memory(proc.pid)
    finally:
        _stop(proc)
    shutil.rmtree(tmp, ignore_errors=True)
    return run


def _stop(proc: subprocess.Popen[bytes]) -> None:
    if proc.poll() is None:
        proc.send_signal(signal.SIGTERM)
        try:
            proc.wait(timeout=60)
            return
        except subprocess.TimeoutExpired:
            pass
    try:
        os.killpg(proc.pid, signal.SIGKILL)
    except ProcessLookupError:
        pass
    proc.wait(timeout=10)


def seeded_cache() -> Path:
    """A user cache folder of the bench's own, holding no remembered check but the
    AgentSpeak parser tables the user's has (built once per grammar, not per start)."""
    cache = Path(tempfile.mkdtemp(prefix="mrss-bench-memory-cache-"))
    (cache / "mrss").mkdir(mode=0o700)
    for tables in usercache.folder().glob("agentspeak-grammar-*.cache"):
        shutil.copy2(tables, cache / "mrss" / tables.name)
    return cache


def bare_interpreter() -> tuple[float, float]:
    """Seconds to start and end `python -P -c pass`; PSS (MiB) of one that sleeps."""
    times = []
    for _ in range(5):
        began = time.perf_counter()
        subprocess.run([sys.executable, "-P", "-c", "pass"], check=True)
        times.append(time.perf_counter() - began)
    sleeper = subprocess.Popen([sys.executable, "-P", "-c", "import time; time.sleep(30)"])
    try:
        time.sleep(0.5)
        pss = pss_mib(sleeper.pid)
    finally:
        sleeper.kill()
        sleeper.wait()
    return statistics.median(times), pss


def run(quick: bool) -> BenchReport:
    starts = 2 if quick else 6
    settle = 2.0 if quick else 8.0
    load_before = os.getloadavg()[0]
    bare_s, bare_pss = bare_interpreter()
    cache = seeded_cache()
    try:  # the first start checks the project; the later ones find that check remembered
        runs = [start_once(settle, cache) for _ in range(starts)]
    finally:
        shutil.rmtree(cache, ignore_errors=True)
    first, later = runs[0], runs[1:]
    report = BenchReport("memory", ["what", "n", "PSS MiB", "threads", "p50 s", "max s"],
                         quick=quick)
    labels = list(runs[-1].pss_mib)
    for name in labels:
        report.add_row(name, len(runs),
                       statistics.median(r.pss_mib.get(name, 0.0) for r in runs),
                       runs[-1].threads.get(name), None, None)
    totals = [r.total for r in runs]
    report.add_row(f"total ({len(labels)} kinds of process)", len(runs),
                   statistics.median(totals), sum(runs[-1].threads.values()), None, None)
    report.add_row("reference: a bare interpreter (python -P), sleeping", 1, bare_pss, 1,
                   None, None)
    start = [r.start_s for r in later]
    report.add_row(f"start: `mrss supervise {PROJECT}` -> {LAST} running (its check "
                   f"remembered)", len(later), None, None, statistics.median(start),
                   max(start))
    report.add_row("  ... -> the root's first line (after its imports)", len(later), None,
                   None, statistics.median(r.root_up_s for r in later),
                   max(r.root_up_s for r in later))
    report.add_row("  ... -> the first component (bus proxy) ready",
                   len(later), None, None, statistics.median(r.first_start_s for r in later),
                   max(r.first_start_s for r in later))
    report.add_row(f"first start -> {LAST} running (the project checked)", 1, None, None,
                   first.start_s, None)
    report.add_row("  ... -> the root's first line (after its imports and the check)", 1,
                   None, None, first.root_up_s, None)
    report.add_row("reference: a bare interpreter, `python -P -c pass`", 5, None, None,
                   bare_s, None)
    report.target(f"the {PROJECT} system's PSS, all processes (MiB, median of {len(runs)})",
                  statistics.median(totals), Relation.AT_MOST, TOTAL_MIB,
                  "the performance issue, on this machine")
    report.target(f"start to a running {LAST}, its check remembered (s, median of "
                  f"{len(later)})", statistics.median(start), Relation.AT_MOST, START_S,
                  "the performance issue, on this machine")
    report.target(f"first start to a running {LAST}, the project checked (s)",
                  first.start_s, Relation.AT_MOST, START_S,
                  "the performance issue, on this machine")
    last = runs[-1]
    report.notes.append(
        "component starts, ms (startup_ms, last run; each starts once the one before is "
        "ready): " + ", ".join(f"{c} {ms:.0f}" for c, ms in last.startup_ms.items()))
    report.notes.append(
        f"PSS {settle:.0f} s after the {LAST} started, from /proc/PID/smaps_rollup over the "
        f"root's process tree (a page shared by n processes counts 1/n in each: the total is "
        f"what the system takes); components are forked from the fork server and share its "
        f"imports; per process the median over the runs, threads from the last run")
    report.notes.append(f"{os.cpu_count()} CPUs, load average {load_before:.2f} before the "
                        f"run, {os.getloadavg()[0]:.2f} after")
    return report
