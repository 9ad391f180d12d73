"""The incident record through real processes: `mrss supervise tuidemo`, an operator's
percept and fault, a component SIGKILLed and restarted, then the root itself killed and
started again on the same run dir; a dashboard attaching late shows the record; every
export format reads it."""

from __future__ import annotations

import csv
import io
import json
import subprocess
import sys
from pathlib import Path

from mrss.incident.entries import Entry, IncidentKind
from mrss.incident.journal import IncidentReader, incident_file
from mrss.messages import Command, Percept
from mrss.testing import wait_until
from mrss.tui.app import MrssApp
from mrss.tui.widgets.log_pane import LogPane
from tests.faults.supervised import Supervised
from tests.tui.tui_helpers import run, until

TUI = Path(__file__).resolve().parent.parent / "tui"  # tuidemo: bus, rcl, reasoner, telemetry


def rows(run_dir: Path) -> list[Entry]:
    """The record's rows so far: its complete lines (the system may be writing the next;
    `read_incident` is for a whole file, whose unfinished last line is a fault)."""
    reader = IncidentReader(incident_file(run_dir))
    entries = reader.read_new()
    assert not reader.problems, reader.problems
    return entries


def first(entries: list[Entry], kind: IncidentKind, text: str) -> int:
    """The position of the first row of `kind` whose text holds `text` (-1: none)."""
    return next((i for i, e in enumerate(entries) if e.kind is kind and text in e.text), -1)


def export(run_dir: Path, fmt: str) -> str:
    proc = subprocess.run([sys.executable, "-m", "mrss", "incident", "export", str(run_dir),
                           "--format", fmt], capture_output=True, text=True, timeout=60)
    assert proc.returncode == 0, proc.stderr
    return proc.stdout


def test_the_record_keeps_goals_faults_and_restarts_in_order_across_a_root_restart(
        tmp_path: Path) -> None:
    run_dir = tmp_path / "run"
    system = Supervised("tuidemo", run_dir, projects=TUI)
    try:
        system.wait_all_running()
        system.pub.publish(Percept("fire(area1)"))  # the operator's percept: a goal
        wait_until(lambda: first(rows(run_dir), IncidentKind.GOAL, "patrol") >= 0,
                   timeout=30, message="the agent's patrol recorded")
        rcl = system.running()["rcl"]["pid"]
        system.pub.publish(Command("fault", target="rcl", args={"fault": "kill"}))
        wait_until(lambda: first(rows(run_dir), IncidentKind.SUPERVISION, "rcl restart") >= 0,
                   timeout=30, message="the rcl's restart recorded")
        assert rcl not in {c["pid"] for c in system.wait_all_running().values()}
    finally:
        system.close()
    # the root started again on the same run dir: it appends, numbering on
    before = rows(run_dir)
    again = Supervised("tuidemo", run_dir, projects=TUI)
    try:
        again.wait_all_running()
        wait_until(lambda: len([e for e in rows(run_dir) if e.kind is IncidentKind.RUN]) >= 3,
                   timeout=30, message="the second run's start recorded")
        entries = rows(run_dir)
        assert entries[:len(before)] == before  # nothing of the first run lost or rewritten
        assert [e.seq for e in entries] == list(range(1, len(entries) + 1))
        order = [first(entries, IncidentKind.RUN, "tuidemo started"),
                 first(entries, IncidentKind.OPERATOR, "percept add fire(area1)"),
                 first(entries, IncidentKind.GOAL, "patrol"),
                 first(entries, IncidentKind.OPERATOR, "ctl.fault rcl fault=kill"),
                 first(entries, IncidentKind.SUPERVISION, "rcl restart"),
                 first(entries, IncidentKind.RUN, "tuidemo stopped")]
        assert -1 not in order and order == sorted(order), (order, entries)
        operator = entries[order[3]]
        assert operator.who == "faults-test"  # the author: the sender's bus name
        assert entries[order[4]].detail["event"] == "restart"
        assert entries[-1].kind is IncidentKind.RUN or len(entries) > len(before)

        # a dashboard attaching late shows the whole record, in its log
        async def body() -> None:
            app = MrssApp(again.sub.endpoints, project="tuidemo", mind_every=0, tree_every=0)
            async with app.run_test(size=(160, 50)) as pilot:
                assert [e.seq for e in app.incident.entries[:len(entries)]] == \
                    [e.seq for e in entries]
                log = app.query_one(LogPane)
                await until(pilot, lambda: any("ctl.fault rcl fault=kill (by faults-test)"
                                               in line for line in log.lines_text()),
                            message="the fault, from the record, in the log")
                assert any("supervision" in line and "rcl restart" in line
                           for line in log.lines_text())
        run(body())
    finally:
        again.close()

    markdown = export(run_dir, "md")
    assert "# Incident record" in markdown and "ctl.fault rcl fault=kill" in markdown
    assert "<td>faults-test</td>" in export(run_dir, "html")
    lines = export(run_dir, "jsonl").splitlines()
    assert [json.loads(line)["seq"] for line in lines] == [e.seq for e in rows(run_dir)]
    table = list(csv.DictReader(io.StringIO(export(run_dir, "csv"))))
    assert [row["text"] for row in table] == [e.text for e in rows(run_dir)]
