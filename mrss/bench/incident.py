"""`mrss bench incident`: a dashboard attaching late to a 4-hour incident record.

A record of a busy 4-hour mission (2 rows a second: goals, outcomes, operator
commands, robot losses, restarts, allocations; ~28,800 rows) is written to a run dir by
the record's own writer; a dashboard (headless Textual, as `mrss tui` runs it) attaches
to that run dir and the time until its log pane shows the record's last row is
measured, Textual's start included; reading the file alone is a row of its own.
Target (issue 31): a late-attaching dashboard shows a 4-hour record in <= 1 s.
"""

from __future__ import annotations

import asyncio
import shutil
import tempfile
import time
from pathlib import Path

from mrss.bench.report import BenchReport, Relation
from mrss.bus import BusEndpoints
from mrss.incident.entries import Entry, IncidentKind, Level
from mrss.incident.journal import IncidentJournal, incident_file, read_incident

HOURS = 4.0
RATE = 2.0  # rows a second of a busy mission
TARGET_S = 1.0
KINDS = [(IncidentKind.GOAL, Level.INFO, "survey(area{n}) on uav{r} for goal scan(area{n})"),
         (IncidentKind.OUTCOME, Level.INFO, "survey on uav{r} for goal scan(area{n}) succeeded"),
         (IncidentKind.OPERATOR, Level.INFO, "ctl.teleop ugv{r} on=True"),
         (IncidentKind.ALLOCATION, Level.INFO, "sample awarded to ugv{r}: nearest, 80 % battery"),
         (IncidentKind.OUTCOME, Level.WARNING, "sample on ugv{r} failed (link_down): no heartbeat"),
         (IncidentKind.ROBOT, Level.ALERT, "uav{r} lost: link down"),
         (IncidentKind.SUPERVISION, Level.WARNING, "bench/rcl restart (#{r}): SIGKILL")]


def write_record(run_dir: Path, rows: int, start: float) -> Path:
    journal = IncidentJournal(incident_file(run_dir))
    for n in range(rows):
        kind, level, text = KINDS[n % len(KINDS)]
        journal.append(Entry(start + n / RATE, kind, text.format(n=n, r=n % 20), level=level,
                             subject=f"scan(area{n})", source="rcl", who="tui" if
                             kind is IncidentKind.OPERATOR else "", detail={"uuid": f"{n:032x}"}))
    journal.close()
    return incident_file(run_dir)


async def _attach(run_dir: Path, last: str) -> tuple[float, int]:
    from mrss.tui.app import MrssApp
    from mrss.tui.widgets.log_pane import LogPane

    began = time.perf_counter()
    app = MrssApp(BusEndpoints.ipc(run_dir), project="bench", mind_every=0, tree_every=0,
                  world_every=0)
    async with app.run_test(size=(200, 50)) as pilot:
        log = app.query_one(LogPane)
        while not any(last in line for line in log.lines_text()[-3:]):
            await pilot.pause(0.005)
        return time.perf_counter() - began, len(app.incident.entries)


def run(quick: bool = False) -> BenchReport:
    hours = 0.1 if quick else HOURS
    rows = int(hours * 3600 * RATE)
    report = BenchReport("incident", ["record", "rows", "MB", "read s", "attach -> shown s"],
                         quick=quick)
    run_dir = Path(tempfile.mkdtemp(prefix="mrss-bench-incident-"))
    try:
        path = write_record(run_dir, rows, time.time() - hours * 3600)
        began = time.perf_counter()
        entries, _ = read_incident(path)
        read = time.perf_counter() - began
        shown, loaded = asyncio.run(_attach(run_dir, entries[-1].text))
        report.add_row(f"{hours:g} h at {RATE:g} rows/s", rows,
                       round(path.stat().st_size / 1e6, 1), round(read, 3), round(shown, 3))
        report.check("the dashboard holds every row of the record", loaded == rows)
        report.target(f"a late-attaching dashboard shows a {hours:g}-hour record in <= "
                      f"{TARGET_S:g} s", shown, Relation.AT_MOST, TARGET_S, "issue 31")
        report.notes.append("attach -> shown: from creating the dashboard (headless Textual "
                            "run_test at 200 x 50, no system on the bus) until its log pane "
                            "shows the record's last row; the pane gets the newest 300 rows "
                            "and a line counting the rest, the dashboard's record "
                            "(`app.incident.entries`) holds all rows")
    finally:
        shutil.rmtree(run_dir, ignore_errors=True)
    return report
