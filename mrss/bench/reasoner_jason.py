"""Issue 12's reasoner programs on Jason itself, for `mrss bench reasoner`'s Jason rows.

Jason is not a dependency and is never downloaded: the rows are measured only when
MRSS_BENCH_JASON_JAR names a jar (or a class path) holding Jason's classes
(`jason.infra.local.RunLocalMAS`) and `java` is on PATH; otherwise the bench says why
they were skipped. The program text is the one `mrss agent` runs (`reasoner_agent`),
unchanged, as the only agent of a one-agent MAS; it times its own rounds with
`.nano_time` and prints them, and the process is ended once every round has been
printed (Jason's MAS does not stop by itself).
"""

from __future__ import annotations

import os
import re
import shutil
import subprocess
import tempfile
import threading
from collections.abc import Callable
from pathlib import Path

JAR_ENV = "MRSS_BENCH_JASON_JAR"

_ROUND = re.compile(r"^\[bench\] round ms (\S+)$")

# Jason's log on the console as "[agent] text" lines, nothing else
_LOGGING = """handlers = java.util.logging.ConsoleHandler
.level = INFO
java.util.logging.ConsoleHandler.level = FINE
java.util.logging.ConsoleHandler.formatter = jason.runtime.MASConsoleLogFormatter
java.level = OFF
javax.level = OFF
sun.level = OFF
"""


def jason_classpath() -> tuple[str | None, str | None, str]:
    """(java, class path, why not) for the Jason rows: both set, or a reason."""
    jar = os.environ.get(JAR_ENV, "")
    java = shutil.which("java")
    if not jar:
        return None, None, (f"Jason not measured: set {JAR_ENV} to a jar of Jason's classes "
                            "(the bench never downloads it)")
    if java is None:
        return None, None, "Jason not measured: no `java` on PATH"
    missing = [p for p in jar.split(os.pathsep) if p and not Path(p).exists()]
    if missing:
        return None, None, f"Jason not measured: {JAR_ENV} names {missing[0]}, which does not exist"
    return java, jar, f"Jason: {jar} run by {java}"


def run_local_mas(java: str, classpath: str, work: Path, mas2j: str,
                  take: Callable[[str], bool], enough: Callable[[], bool],
                  timeout: float) -> list[str]:
    """Run `work/mas2j` on Jason's Local infrastructure, handing each line it prints to
    `take` (True: a line of results) until `enough()`, Jason exits or `timeout` seconds
    pass (its MAS does not stop by itself; a silent one is ended too). Returns the last
    lines that were not results, for an error message."""
    (work / "logging.properties").write_text(_LOGGING)
    proc = subprocess.Popen([java, "-cp", classpath, "jason.infra.local.RunLocalMAS",
                             mas2j, "--log-conf", "logging.properties"], cwd=work,
                            stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True)
    tail: list[str] = []
    watchdog = threading.Timer(timeout, proc.kill)
    watchdog.start()
    try:
        assert proc.stdout is not None
        for line in proc.stdout:
            if not take(line):
                tail = (tail + [line.strip()])[-5:]
            elif enough():
                break
    finally:
        watchdog.cancel()
        proc.kill()
        proc.wait()
    return tail


def best_round_ms(program: str, n: int, rounds: int, java: str, classpath: str,
                  timeout: float) -> float:
    """The fastest round, in ms, of `program` (reasoner_agent.COUNT or SEEN) on Jason."""
    times: list[float] = []

    def take(line: str) -> bool:
        m = _ROUND.match(line.strip())
        if m:
            times.append(float(m.group(1)))
        return m is not None

    with tempfile.TemporaryDirectory(prefix="mrss-bench-jason-") as tmp:
        work = Path(tmp)
        (work / "bench.asl").write_text(program.format(n=n, rounds=rounds), encoding="utf-8")
        (work / "bench.mas2j").write_text("MAS bench { agents: bench bench.asl; }\n")
        tail = run_local_mas(java, classpath, work, "bench.mas2j", take,
                             lambda: len(times) == rounds, timeout)
    if len(times) != rounds:
        raise RuntimeError(f"Jason printed {len(times)} of {rounds} rounds: "
                           + " | ".join(tail)[-300:])
    return min(times)
