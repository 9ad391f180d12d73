"""Issue 12's reasoner measurements, as a user sees them: programs run by `mrss agent`.

Each program times its own rounds with `.nano_time` and prints one line per round;
the benchmark runs it as `python -m mrss agent FILE` in a subprocess and keeps the
best round (the issue's "best of 5 rounds in one process"). The start-up figure is the
wall time of a whole `mrss agent` run of a one-line program. The memory figure is the
peak RSS of a fresh process holding many beliefs and many intentions blocked on
environment actions.
"""

from __future__ import annotations

import json
import re
import subprocess
import sys
import tempfile
import time
from pathlib import Path

from mrss.interpreter import python_module

# the issue's shapes: recursive sub-goals, and a belief added and removed per round
# against three `+seen` plans with contexts and one `-seen` plan
COUNT = """!rounds({rounds}).
+!rounds(0).
+!rounds(K) : K > 0 <-
    .nano_time(T0); !count(0, {n}); .nano_time(T1);
    .print("round ms ", (T1 - T0) / 1000000); !rounds(K - 1).
+!count(I, N) : I < N <- !count(I + 1, N).
+!count(N, N).
"""

SEEN = """!rounds({rounds}).
+!rounds(0).
+!rounds(K) : K > 0 <-
    .nano_time(T0); !loop(0, {n}); .nano_time(T1);
    .print("round ms ", (T1 - T0) / 1000000); !rounds(K - 1).
+!loop(I, N) : I < N <- +seen(I); -seen(I); !loop(I + 1, N).
+!loop(N, N).
+seen(X) : X mod 2 == 0 <- true.
+seen(X) : X mod 3 == 0 <- true.
+seen(X) <- true.
-seen(X) <- true.
"""

# what issue 12 measured through `mrss agent` before (ms per round), and the target
ISSUE_MS = {"count": 990.0, "seen": 790.0}
ISSUE_SIZE = {"count": 100_000, "seen": 20_000}
SPEEDUP = 3.0
RSS_LIMIT_MB = 200.0

_ROUND = re.compile(r"^round ms (\S+)$")


def best_round_ms(program: str, n: int, rounds: int, timeout: float) -> float:
    """The fastest round, in ms, of `program` (COUNT or SEEN) run by `mrss agent`."""
    with tempfile.TemporaryDirectory(prefix="mrss-bench-") as tmp:
        path = Path(tmp) / "bench.asl"
        path.write_text(program.format(n=n, rounds=rounds), encoding="utf-8")
        proc = subprocess.run(python_module("mrss", "agent", str(path)),
                              capture_output=True, text=True, timeout=timeout)
    times = [float(m.group(1)) for line in proc.stdout.splitlines()
             if (m := _ROUND.match(line.strip()))]
    if proc.returncode != 0 or len(times) != rounds:
        raise RuntimeError(f"mrss agent exited {proc.returncode} after {len(times)} of "
                           f"{rounds} rounds: {proc.stderr.strip()[-300:]}")
    return min(times)


def startup_ms(runs: int, timeout: float) -> float:
    """The fastest wall time, in ms, of `mrss agent` running a one-line program: what a
    run costs before the agent's first cycle (imports, parsing, exit)."""
    best = float("inf")
    with tempfile.TemporaryDirectory(prefix="mrss-bench-") as tmp:
        path = Path(tmp) / "hello.asl"
        path.write_text("!hello.\n+!hello <- .print(hi).\n", encoding="utf-8")
        for _ in range(runs):
            t = time.perf_counter()
            proc = subprocess.run(python_module("mrss", "agent", str(path)),
                                  capture_output=True, text=True, timeout=timeout)
            elapsed = (time.perf_counter() - t) * 1000
            if proc.returncode != 0 or proc.stdout.strip() != "hi":
                raise RuntimeError(f"mrss agent exited {proc.returncode}: "
                                   f"{proc.stderr.strip()[-300:]}")
            best = min(best, elapsed)
    return best


MEMORY_PROGRAM = """+go(I) <- act(I); +done(I).
"""


def memory_child(beliefs: int, blocked: int) -> dict[str, float]:
    """In this process: an agent with `beliefs` beliefs (indexed by first argument) and
    `blocked` intentions parked on actions; the peak RSS in MB."""
    import resource

    from mrss.agentspeak.agent import Agent
    from mrss.agentspeak.terms import Struct

    class Holding:
        def __init__(self) -> None:
            self.n = 0

        def execute(self, action: Struct, intention_id: int) -> int:
            self.n += 1
            return self.n

        def cancel(self, handle: object) -> None:
            pass

    host = Holding()
    agent = Agent(MEMORY_PROGRAM, name="memory", host=host, out=lambda _: None)
    for i in range(beliefs):
        agent.bb.add(Struct("fact", (i, f"item{i}", Struct("pos", (i * 0.5, i * 0.25)))))
    for i in range(blocked):
        agent.add_percept(Struct("go", (i,)))
    agent.run_until_idle()
    assert agent.bb.size >= beliefs + blocked and len(agent.pending_actions) == blocked
    # a query with a bound first argument: the predicate's first-argument index is built
    assert agent.believes(f"fact({beliefs // 2}, _, _)")
    rss_kb = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss  # KB on Linux
    return {"rss_mb": rss_kb / 1024.0}


def peak_rss_mb(beliefs: int, blocked: int, timeout: float) -> float:
    """The peak RSS (MB) of a fresh process running `memory_child`."""
    proc = subprocess.run(python_module("mrss.bench.reasoner_agent", "memory",
                                        str(beliefs), str(blocked)),
                          capture_output=True, text=True, timeout=timeout)
    if proc.returncode != 0:
        raise RuntimeError(proc.stderr.strip()[-300:] or f"exit {proc.returncode}")
    result: dict[str, float] = json.loads(proc.stdout.strip().splitlines()[-1])
    return result["rss_mb"]


if __name__ == "__main__":  # the memory child: python -m mrss.bench.reasoner_agent memory B I
    if len(sys.argv) == 4 and sys.argv[1] == "memory":
        print(json.dumps(memory_child(int(sys.argv[2]), int(sys.argv[3]))))
    else:
        sys.exit("usage: python -m mrss.bench.reasoner_agent memory BELIEFS BLOCKED")
