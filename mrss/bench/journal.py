"""`mrss bench journal`: action journal throughput (with and without fsync) and its size
over a simulated 24-hour soak with compaction (a stepped clock: minutes of wall time).

Each action is journaled as the RCL does for a short one: PENDING, RUNNING, SUCCEEDED
(three committed transitions). The soak runs 1M actions (quick: 5k) through a journal
whose clock spreads them evenly over 24 simulated hours; it compacts every simulated
10 minutes, keeping ended actions for 1 hour and always the newest 1000, as the RCL's
timer does. The target: the file does not grow after the first hours (the size at the
end stays within 1.5x of the size after 2 hours).
"""

from __future__ import annotations

import tempfile
import time
from pathlib import Path

from mrss.actors.rcl.journal import ActionJournal
from mrss.api import Action, ActionState
from mrss.bench.report import BenchReport, Relation

DAY = 86400.0
SIMULATED = "simulated 24 h soak, clock stepped"
KEEP_SECONDS = 3600.0
KEEP_LAST = 1000
COMPACT_EVERY = 600.0


def _journal_action(journal: ActionJournal, i: int) -> None:
    action = Action(uuid=f"a{i}", name="patrol", args=["ugv1", f"g{i}", ["p1", "p2"]],
                    robot="ugv1", goal=f"g{i}", priority=1, literal=f"patrol(ugv1,g{i})")
    journal.record(action)
    action.transition(ActionState.RUNNING)
    journal.record(action)
    action.progress["waypoint"] = 2
    action.transition(ActionState.SUCCEEDED)
    journal.record(action)


def _throughput(path: Path, actions: int, durable: bool) -> tuple[float, int]:
    journal = ActionJournal(path, durable=durable)
    try:
        start = time.perf_counter()
        for i in range(actions):
            _journal_action(journal, i)
        elapsed = time.perf_counter() - start
        return actions / elapsed, journal.size()
    finally:
        journal.close()


def _soak(path: Path, actions: int) -> tuple[float, int, int, int, int]:
    """(actions/s, size after 2 simulated hours, peak size, final size, dropped)."""
    now = [0.0]
    journal = ActionJournal(path, clock=lambda: now[0])
    step = DAY / actions
    next_compaction, at_two_hours, peak, dropped = COMPACT_EVERY, 0, 0, 0
    try:
        start = time.perf_counter()
        for i in range(actions):
            now[0] = i * step
            _journal_action(journal, i)
            if now[0] >= next_compaction:
                next_compaction += COMPACT_EVERY
                dropped += journal.compact(KEEP_SECONDS, KEEP_LAST)
                size = journal.size()
                peak = max(peak, size)
                if not at_two_hours and now[0] >= 2 * 3600.0:
                    at_two_hours = size
        elapsed = time.perf_counter() - start
        dropped += journal.compact(KEEP_SECONDS, KEEP_LAST)
        return actions / elapsed, at_two_hours, peak, journal.size(), dropped
    finally:
        journal.close()


def run(quick: bool = False) -> BenchReport:
    plain, synced, soaked = (300, 100, 5_000) if quick else (20_000, 2_000, 1_000_000)
    report = BenchReport("journal", ["case", "actions", "actions/s", "journal MB"],
                         quick=quick)
    mb = 1024.0 * 1024.0
    with tempfile.TemporaryDirectory(prefix="mrss-bench-journal-") as tmp:
        base = Path(tmp)
        rate, size = _throughput(base / "plain.sqlite3", plain, durable=False)
        report.add_row("no fsync (synchronous=NORMAL)", plain, rate, size / mb)
        rate, size = _throughput(base / "durable.sqlite3", synced, durable=True)
        report.add_row("fsync every commit (durable=True)", synced, rate, size / mb)
        rate, two_hours, peak, final, dropped = _soak(base / "soak.sqlite3", soaked)
        wall = soaked / rate
        soak = f"{SIMULATED} ({wall:.0f} s of wall time)"
        report.add_row(f"{soak}, compacted: after 2 simulated h", soaked, None, two_hours / mb)
        report.add_row(f"{soak}, compacted: peak", soaked, None, peak / mb)
        report.add_row(f"{soak}, compacted: at the end", soaked, rate, final / mb)
    report.target("the journal stays bounded: size after 24 simulated h <= 1.5x size after "
                  "2 simulated h", final / mb, Relation.AT_MOST, 1.5 * two_hours / mb,
                  f"1.5 x the size after 2 simulated h ({two_hours / mb:.2f} MB)")
    report.notes.append(f"3 transitions per action; soak keeps ended actions {KEEP_SECONDS:.0f}"
                        f" s and the newest {KEEP_LAST}, compacts every {COMPACT_EVERY:.0f} "
                        f"simulated s; {dropped:,} actions compacted away")
    report.notes.append(
        f"the soak is not 24 hours long: its {soaked:,} actions run as fast as they can "
        f"({wall:.0f} s of wall time) through a journal whose clock is stepped over 24 h, "
        "so it shows the size compaction keeps, not a day of a real disk, WAL and process")
    return report
