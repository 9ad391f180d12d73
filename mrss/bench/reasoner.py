"""`mrss bench reasoner`: our AgentSpeak interpreter against python-agentspeak 0.2.2.

(a) a chain of recursive achievement sub-goals, (b) percepts each matched against plans
with contexts (one percept at a time, each processed until idle), (c) the cost of a
reasoning cycle while many intentions are blocked on environment actions, and of
releasing them; (d), (e), (f) and (g) are issue 12's programs through `mrss agent`,
the start-up of `mrss agent` and issue 12's memory figure (`reasoner_agent`).
python-agentspeak is installed by this benchmark into a throwaway venv under the user
cache directory (never a dependency of MRSS) and run in a subprocess. With
MRSS_BENCH_JASON_JAR naming Jason's classes, (d) and (e) also run on Jason in the same
run (`reasoner_jason`), with our speed relative to Jason's; never downloaded.
"""

from __future__ import annotations

import fcntl
import json
import subprocess
import sys
import time
from collections.abc import Hashable
from pathlib import Path

from mrss import usercache
from mrss.agentspeak.agent import Agent
from mrss.agentspeak.terms import Struct
from mrss.bench import reasoner_agent as ia
from mrss.bench import reasoner_jason as jason
from mrss.bench.report import BenchReport

PEER = "agentspeak==0.2.2"
TARGET = 1.5

PROGRAM_A = """!count({n}).
+!count(0) <- .print(done).
+!count(N) : N > 0 <- !count(N - 1).
"""

PROGRAM_B = """threshold(50).
+item(X, V) : V > 90 & threshold(T) <- +high(X).
+item(X, V) : V > 50 & threshold(T) & V > T <- +medium(X).
+item(X, V) : V <= 50 <- true.
"""

PROGRAM_C = """+go(I) <- act(I); +done(I).
+!spin(0).
+!spin(N) : N > 0 <- !spin(N - 1).
"""

# Runs inside the peer's venv; prints {"a": goals/s, "b": events/s} as JSON.
PEER_SCRIPT = r'''
import contextlib, io, json, sys, time
import agentspeak, agentspeak.runtime, agentspeak.stdlib

def named(src):
    f = io.StringIO(src)
    f.name = "bench.asl"
    return f

def run_a(n):
    env = agentspeak.runtime.Environment()
    out = io.StringIO()
    with contextlib.redirect_stdout(out):
        env.build_agent(named(PROGRAM_A.format(n=n)), agentspeak.stdlib.actions)
        t = time.process_time()
        env.run()
        dt = time.process_time() - t
    assert "done" in out.getvalue(), out.getvalue()
    return n / dt

def run_b(m):
    env = agentspeak.runtime.Environment()
    agent = env.build_agent(named(PROGRAM_B), agentspeak.stdlib.actions)
    t = time.process_time()
    for i in range(m):
        agent.call(agentspeak.Trigger.addition, agentspeak.GoalType.belief,
                   agentspeak.Literal("item", (i, i % 100)), agentspeak.runtime.Intention())
        env.run()
    dt = time.process_time() - t
    assert len(agent.beliefs[("medium", 1)]) > 0
    return m / dt

n, m, repeats = int(sys.argv[1]), int(sys.argv[2]), int(sys.argv[3])
print(json.dumps({"a": max(run_a(n) for _ in range(repeats)),
                  "b": max(run_b(m) for _ in range(repeats))}))
'''


class _HoldingHost:
    """Keeps every action open until released."""

    def __init__(self) -> None:
        self.handles: list[int] = []

    def execute(self, action: Struct, intention_id: int) -> Hashable:
        self.handles.append(len(self.handles) + 1)
        return self.handles[-1]

    def cancel(self, handle: Hashable) -> None:
        pass


def _quiet(_: str) -> None:
    pass


def ours_a(n: int) -> float:
    lines: list[str] = []
    agent = Agent(PROGRAM_A.format(n=n), name="bench", out=lines.append)
    t = time.process_time()
    agent.run_until_idle()
    dt = time.process_time() - t
    assert lines == ["done"], lines
    return n / dt


def ours_b(m: int) -> float:
    agent = Agent(PROGRAM_B, name="bench", out=_quiet)
    t = time.process_time()
    for i in range(m):
        agent.add_percept(Struct("item", (i, i % 100)))
        agent.run_until_idle()
    dt = time.process_time() - t
    assert agent.believes("medium(_)") and agent.believes("high(_)")
    return m / dt


def ours_c(blocked: int, spin: int) -> tuple[float, float]:
    """µs per cycle of an unrelated intention with `blocked` intentions parked on
    actions, and µs per released intention when all actions then succeed."""
    host = _HoldingHost()
    agent = Agent(PROGRAM_C, name="bench", host=host, out=_quiet)
    for i in range(blocked):
        agent.add_percept(Struct("go", (i,)))
    agent.run_until_idle()
    assert len(agent.pending_actions) == blocked
    agent.add_goal(Struct("spin", (spin,)))
    c0 = agent.cycle
    t = time.process_time()
    agent.run_until_idle()
    per_cycle = (time.process_time() - t) / (agent.cycle - c0) * 1e6
    t = time.process_time()
    for h in host.handles:
        agent.complete_action(h, True)
    agent.run_until_idle()
    per_release = (time.process_time() - t) / blocked * 1e6 if blocked else 0.0
    done = agent.bb.store(("done", 1, False))
    assert not agent.intentions and len(done or ()) == blocked
    return per_cycle, per_release


def _cache_dir() -> Path:
    return usercache.base() / "mrss-bench" / "peer-agentspeak-0.2.2"


def peer_python(timeout: float) -> tuple[Path | None, str]:
    """The venv python with python-agentspeak 0.2.2, installing it if needed.

    One process installs at a time (a lock file beside the venv): a second bench or test
    waits for the first install and then uses it, rather than clearing the venv under it.
    `timeout` bounds the install (a loaded machine's pip is slow: it is no speed target).
    """
    venv = _cache_dir()
    python = venv / "bin" / "python"
    marker = venv / "installed.ok"
    venv.parent.mkdir(parents=True, exist_ok=True)
    with open(venv.with_name(venv.name + ".lock"), "w") as lock:
        fcntl.flock(lock, fcntl.LOCK_EX)
        if marker.exists() and python.exists():
            return python, "python-agentspeak 0.2.2 from the cached venv " + str(venv)
        try:
            t = time.monotonic()
            subprocess.run([sys.executable, "-m", "venv", "--clear", str(venv)], check=True,
                           capture_output=True, timeout=timeout)
            left = max(timeout - (time.monotonic() - t), 1.0)
            subprocess.run([str(python), "-m", "pip", "install", "-q", PEER], check=True,
                           capture_output=True, timeout=left)
        except (subprocess.SubprocessError, OSError) as exc:
            return None, (f"python-agentspeak 0.2.2 could not be installed "
                          f"({type(exc).__name__})")
        marker.write_text(PEER + "\n")
    return python, f"python-agentspeak 0.2.2 installed into {venv}"


def run_peer(python: Path, n: int, m: int, repeats: int, timeout: float) -> dict[str, float]:
    script = f"PROGRAM_A = {PROGRAM_A!r}\nPROGRAM_B = {PROGRAM_B!r}\n" + PEER_SCRIPT
    proc = subprocess.run([str(python), "-c", script, str(n), str(m), str(repeats)],
                          capture_output=True, text=True, timeout=timeout)
    if proc.returncode != 0:
        raise RuntimeError(proc.stderr.strip().splitlines()[-1] if proc.stderr else "failed")
    result: dict[str, float] = json.loads(proc.stdout.strip().splitlines()[-1])
    return result


def run(quick: bool) -> BenchReport:
    n, m = (20_000, 5_000) if quick else (100_000, 20_000)
    repeats = 3
    blocked_sizes = [0, 1_000] if quick else [0, 1_000, 10_000]
    spin = 5_000 if quick else 20_000
    report = BenchReport("reasoner", ["benchmark", "size", "ours", "python-agentspeak 0.2.2",
                                      "ratio", "unit"], quick=quick)

    a = max(ours_a(n) for _ in range(repeats))
    b = max(ours_b(m) for _ in range(repeats))
    peer: dict[str, float] | None = None
    python, note = peer_python(timeout=300)
    if python is not None:
        try:
            peer = run_peer(python, n, m, 2 if quick else 3, timeout=60 if quick else 900)
        except (RuntimeError, subprocess.SubprocessError, ValueError) as exc:
            note = f"python-agentspeak 0.2.2 did not run: {exc}"
    report.notes.append(note)
    for label, size, ours, key, unit in (
            ("(a) recursive sub-goals", n, a, "a", "goals/s"),
            ("(b) percepts vs plans with contexts", m, b, "b", "events/s")):
        theirs = peer[key] if peer else None
        ratio = ours / theirs if theirs else None
        report.add_row(label, size, ours, theirs, ratio, unit)
        if ratio is not None:
            report.check(f"{label}: >= {TARGET}x python-agentspeak (got {ratio:.2f}x)",
                         ratio >= TARGET)
    costs = []
    for blocked in blocked_sizes:
        runs = [ours_c(blocked, spin) for _ in range(repeats)]
        per_cycle = min(r[0] for r in runs)
        per_release = min(r[1] for r in runs)
        costs.append(per_cycle)
        report.add_row(f"(c) cycle cost, {blocked:,} intentions blocked", spin, per_cycle,
                       None, None, "µs/cycle")
        if blocked:
            report.add_row(f"(c) release {blocked:,} blocked intentions", blocked,
                           per_release, None, None, "µs/intention")
    growth = max(costs) / costs[0]
    report.check(f"(c) per-cycle cost does not grow with blocked intentions "
                 f"(max/min {growth:.2f}, limit 1.5)", growth <= 1.5)
    _through_mrss_agent(report, quick)
    report.notes.append("throughput and costs are CPU time (time.process_time) of the "
                        "interpreter's process, best of several runs: the machine is shared")
    report.notes.append("(b) feeds one percept at a time and runs each until idle, in both "
                        "interpreters; (c) is ours only: python-agentspeak has no asynchronous "
                        "actions (its step scans every intention)")
    report.notes.append("(d) and (e) are issue 12's programs run by `mrss agent` in a "
                        "subprocess, timed by the program itself (.nano_time, wall clock): "
                        "the best round; (f) is the wall time of a whole `mrss agent` run, "
                        "best of several; (g) the peak RSS of a fresh process")
    return report


def _jason_rows(report: BenchReport, label: str, program: str, n: int, rounds: int,
                ours_ms: float, java: str, classpath: str, quick: bool) -> None:
    """The same program on Jason (best round, as ours), and our speed relative to it."""
    try:
        theirs = jason.best_round_ms(program, n, rounds, java, classpath,
                                     timeout=120 if quick else 600)
    except (RuntimeError, OSError) as exc:
        report.notes.append(f"{label} on Jason did not run: {exc}")
        return
    report.add_row(label.replace("via mrss agent", "on Jason"), n, theirs, None, None,
                   "ms/round")
    ratio = theirs / ours_ms
    report.add_row(label.replace("via mrss agent", "speed vs Jason"), n, ratio, None, None,
                   "x Jason")
    if not quick:
        report.check(f"{label}: >= 1.0x Jason's speed (got {ratio:.2f}x)", ratio >= 1.0)


def _through_mrss_agent(report: BenchReport, quick: bool) -> None:
    """Issue 12's two programs through `mrss agent`, its start-up, the memory figure."""
    rounds = 3 if quick else 5
    java, classpath, why = jason.jason_classpath()
    report.notes.append(why)
    for key, label, program in (
            ("count", "(d) recursive sub-goals via mrss agent", ia.COUNT),
            ("seen", "(e) +seen/-seen vs 3 plans via mrss agent", ia.SEEN)):
        n = ia.ISSUE_SIZE[key] // (5 if quick else 1)
        try:
            ms = ia.best_round_ms(program, n, rounds, timeout=120 if quick else 600)
        except (RuntimeError, subprocess.SubprocessError) as exc:
            report.notes.append(f"{label} did not run: {exc}")
            continue
        report.add_row(label, n, ms, None, None, "ms/round")
        if java is not None and classpath is not None:
            _jason_rows(report, label, program, n, rounds, ms, java, classpath, quick)
        if not quick:
            limit = ia.ISSUE_MS[key] / ia.SPEEDUP
            report.check(f"{label}: <= {limit:.0f} ms ({ia.SPEEDUP:g}x faster than issue 12's "
                         f"{ia.ISSUE_MS[key]:.0f} ms; got {ms:.0f} ms)", ms <= limit)
    try:
        start = ia.startup_ms(3 if quick else 5, timeout=60)
        report.add_row("(f) mrss agent start-up, one-line program", 1, start, None, None,
                       "ms")
    except (RuntimeError, subprocess.SubprocessError) as exc:
        report.notes.append(f"(f) start-up did not run: {exc}")
    beliefs, blocked = (20_000, 2_000) if quick else (100_000, 10_000)
    try:
        rss = ia.peak_rss_mb(beliefs, blocked, timeout=120 if quick else 600)
    except (RuntimeError, subprocess.SubprocessError, ValueError) as exc:
        report.notes.append(f"(g) memory did not run: {exc}")
        return
    report.add_row(f"(g) peak RSS, {beliefs:,} beliefs + {blocked:,} blocked intentions",
                   beliefs, rss, None, None, "MB")
    if not quick:
        report.check(f"(g) {beliefs:,} beliefs and {blocked:,} blocked intentions in <= "
                     f"{ia.RSS_LIMIT_MB:.0f} MB RSS (got {rss:.0f} MB)", rss <= ia.RSS_LIMIT_MB)
