"""`mrss bench agents`: many small agents in one process, exchanging `.send` messages.

N agents of one society form a ring (each one's initial belief `next(Name)` names the
next) and pass `achieve ping(K)` on, K + 1 each time, in two patterns (`Pattern`):
every agent sends a ping at the start (N pings in flight, every agent busy in every
round), or one agent does (a single token: one agent busy at a time, the case where
a scheduler that looks at every agent costs most). Each agent believes `done` at its
last ping; the run ends when all are idle, and the bench checks that every one
believes `done`. The same message total is kept across sizes, so the rows compare
how the cost of a reasoning cycle grows with the number of agents; the figure is
reasoning cycles per second of CPU (busy cycles: those that did something, counted
in an untimed run of the same program), with the 1-agent row as the reference.

Memory per agent: tracemalloc's traced bytes after building the N agents and after
their run, divided by N; and the process's RSS growth over the same span, divided by N.

With MRSS_BENCH_JASON_JAR naming Jason's classes and `java` on PATH (see
`reasoner_jason`), the same program runs as N agents of a `.mas2j` under Jason's
Local infrastructure; each agent prints `.nano_time` at its start and at `done`, and
the span from the first start to the last `done` is compared with ours. Never
downloaded: without them the row is skipped with the reason.
"""

from __future__ import annotations

import enum
import gc
import os
import tempfile
import time
import tracemalloc
from collections.abc import Callable
from pathlib import Path

from mrss.agentspeak.agent import Agent
from mrss.agentspeak.society import Society
from mrss.bench import reasoner_jason as jason
from mrss.bench.report import BenchReport, Relation

RING = """!start.
+!start : starter & next(N) <- .nano_time(T); .print("start ", T); .send(N, achieve, ping(1)).
+!start.
+!ping(K) : stop(K) <- +done; .nano_time(T); .print("done ", T).
+!ping(K) : last_lap(L) & K >= L & next(N) <-
    +done; .nano_time(T); .print("done ", T); K2 = K + 1; .send(N, achieve, ping(K2)).
+!ping(K) : next(N) <- K2 = K + 1; .send(N, achieve, ping(K2)).
"""


class Pattern(enum.Enum):
    """Who starts: every agent (N pings in flight, every agent busy in every round), or
    one agent (a single token going round: one agent busy at a time)."""

    EVERY = "every agent sends"
    TOKEN = "one token"


def beliefs(pattern: Pattern, i: int, n: int, messages: int) -> list[str]:
    """Agent i's initial beliefs: its next, whether it starts, and when it is done."""
    if pattern is Pattern.EVERY:  # each agent is sent pings 1..R, R = messages / n
        rounds = max(messages // n, 1)
        stop, last_lap, starter = rounds, rounds, True
    else:  # hops 1..H go round the ring; the last n of them visit every agent once
        stop, last_lap, starter = messages, messages - n + 1, i == 0
    return ([f"next({name((i + 1) % n)})", f"stop({stop})", f"last_lap({last_lap})"]
            + (["starter"] if starter else []))

MESSAGES = 100_000  # N x R at every size (full)
QUICK_MESSAGES = 20_000
CLOSE = 0.8  # cycles/s at the largest size >= CLOSE x cycles/s at 1 agent


def name(i: int) -> str:
    return f"a{i + 1}"


def _quiet(_: str) -> None:
    pass


def build(pattern: Pattern, n: int, messages: int) -> Society:
    """The ring of `n` agents, `messages` pings in all."""
    society = Society(out=_quiet)
    for i in range(n):
        agent = Agent(RING, file="ring.asl", name=name(i), actions=society.registry,
                      beliefs=beliefs(pattern, i, n, messages), out=_quiet)
        society.join(agent)
    return society


def all_done(society: Society) -> bool:
    return all(a.believes("done") for a in society.agents.values())


def busy_cycles(pattern: Pattern, n: int, messages: int) -> int:
    """The reasoning cycles that did something in a run of the ring (untimed)."""
    society = build(pattern, n, messages)
    count = 0
    for agent in society.agents.values():
        step = agent.step

        def counted(step: Callable[[], bool] = step) -> bool:
            nonlocal count
            busy = step()
            count += busy
            return busy

        agent.step = counted  # type: ignore[method-assign]
    society.run()
    assert all_done(society)
    return count


def timed_run(pattern: Pattern, n: int, messages: int) -> float:
    """CPU seconds of one run of the ring (building it is not timed)."""
    society = build(pattern, n, messages)
    gc.collect()
    t = time.process_time()
    idle = society.run()
    dt = time.process_time() - t
    assert idle and all_done(society), "a ring agent did not reach done"
    return dt


def build_seconds(n: int) -> float:
    """CPU seconds to build `n` agents of the ring (parse, compile, initial beliefs)."""
    t = time.process_time()
    build(Pattern.EVERY, n, n)
    return time.process_time() - t


def _rss_bytes() -> int:
    with open("/proc/self/statm") as f:
        return int(f.read().split()[1]) * os.sysconf("SC_PAGE_SIZE")


def memory_per_agent(pattern: Pattern, n: int, messages: int) -> tuple[float, float, float]:
    """(traced KB per agent built, traced KB per agent after the run, RSS growth in KB
    per agent after the run)."""
    gc.collect()
    rss0 = _rss_bytes()
    tracemalloc.start()
    try:
        base = tracemalloc.get_traced_memory()[0]
        society = build(pattern, n, messages)
        built = tracemalloc.get_traced_memory()[0] - base
        society.run()
        assert all_done(society)
        gc.collect()
        ran = tracemalloc.get_traced_memory()[0] - base
    finally:
        tracemalloc.stop()
    rss = _rss_bytes() - rss0
    del society
    return built / n / 1024, ran / n / 1024, rss / n / 1024


def mas2j(pattern: Pattern, n: int, messages: int) -> str:
    lines = []
    for i in range(n):
        given = ",".join(beliefs(pattern, i, n, messages))
        lines.append(f'    {name(i)} ring.asl [beliefs="{given}"];')
    return "MAS ring {\n  agents:\n" + "\n".join(lines) + "\n}\n"


def jason_span_ms(pattern: Pattern, n: int, messages: int, java: str, classpath: str,
                  timeout: float) -> float:
    """ms from the first agent's start to the last agent's `done` under Jason's Local
    infrastructure (the JVM's start and the agents' creation are not in it)."""
    starts: list[int] = []
    dones: list[int] = []

    def take(line: str) -> bool:
        words = line.split()
        if len(words) < 3 or words[-2] not in ("start", "done"):
            return False
        (starts if words[-2] == "start" else dones).append(int(float(words[-1])))
        return True

    with tempfile.TemporaryDirectory(prefix="mrss-bench-jason-") as tmp:
        work = Path(tmp)
        (work / "ring.asl").write_text(RING, encoding="utf-8")
        (work / "ring.mas2j").write_text(mas2j(pattern, n, messages), encoding="utf-8")
        tail = jason.run_local_mas(java, classpath, work, "ring.mas2j", take,
                                   lambda: len(dones) == n, timeout)
    if len(dones) != n or not starts:
        raise RuntimeError(f"Jason printed {len(dones)} of {n} done lines: "
                           + " | ".join(tail)[-300:])
    return (max(dones) - min(starts)) / 1e6


def run(quick: bool) -> BenchReport:
    messages = QUICK_MESSAGES if quick else MESSAGES
    sizes = [1, 100, 1_000] if quick else [1, 10, 100, 1_000]
    repeats = 2 if quick else 3
    report = BenchReport("agents", ["pattern", "agents", "busy cycles", "CPU ms", "cycles/s",
                                    "vs 1 agent", "KB/agent built", "KB/agent after run",
                                    "RSS KB/agent"], quick=quick)
    big = 1_000
    for pattern in Pattern:
        rates: dict[int, float] = {}
        for n in sizes:
            cycles = busy_cycles(pattern, n, messages)
            seconds = min(timed_run(pattern, n, messages) for _ in range(repeats))
            rates[n] = cycles / seconds
            memory: tuple[float | None, ...] = (None, None, None)
            if n >= 100 and pattern is Pattern.EVERY:
                memory = memory_per_agent(pattern, n, messages)
            report.add_row(pattern.value, n, cycles, seconds * 1000, rates[n],
                           rates[n] / rates[1], *memory)
        report.target(f"{pattern.value}: cycles/s with {big:,} agents close to 1 agent's",
                      rates[big] / rates[1], Relation.AT_LEAST, CLOSE,
                      "the 1-agent row of this run")
    for n in sizes[-2:]:
        report.add_row("building the agents", n, None, build_seconds(n) * 1000, None,
                       None, None, None, None)
    java, classpath, why = jason.jason_classpath()
    report.notes.append(why)
    if java is not None and classpath is not None:
        for pattern in Pattern:
            try:
                theirs = jason_span_ms(pattern, big, messages, java, classpath,
                                       timeout=120 if quick else 600)
            except (RuntimeError, OSError, ValueError) as exc:
                report.notes.append(f"{pattern.value} on Jason did not run: {exc}")
                continue
            ours = min(timed_run(pattern, big, messages) for _ in range(repeats)) * 1000
            report.add_row(f"{pattern.value}, Jason 3.1 Local (wall ms)", big, None, theirs,
                           None, None, None, None, None)
            report.notes.append(f"{pattern.value}, {big:,} agents: Jason {theirs:.0f} ms "
                                f"(first start to last done), ours {ours:.0f} ms: "
                                f"{theirs / ours:.2f}x Jason's speed")
    report.notes.append(f"{messages:,} messages in all at every size; cycles/s is busy "
                        "reasoning cycles (those that did something) per CPU second "
                        "(time.process_time), best of several runs: the machine is shared")
    report.notes.append("memory: a separate run of the same ring with tracemalloc on (bytes "
                        "Python allocated and still holds, per agent) and this process's "
                        "RSS growth over it, per agent")
    return report
