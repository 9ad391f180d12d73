"""The incident file on its own: appends across reopenings, and a damaged file read
with every good row kept and each bad line named by line and byte offset."""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

from mrss.incident.entries import Entry, IncidentKind, Level
from mrss.incident.journal import IncidentJournal, incident_file, read_incident


def write(run_dir: Path, *texts: str) -> None:
    journal = IncidentJournal(incident_file(run_dir))
    for i, text in enumerate(texts):
        journal.append(Entry(1000.0 + i, IncidentKind.OPERATOR, text, level=Level.WARNING,
                             who="tui"))
    journal.close()


def test_a_reopened_record_numbers_on_and_a_row_cut_short_stays_alone(tmp_path: Path) -> None:
    write(tmp_path, "one", "two")
    path = incident_file(tmp_path)
    with path.open("ab") as f:
        f.write(b'{"seq":3,"ts":1.0,"kind":"op')  # the root killed mid-row
    entries, problems = read_incident(path)
    assert [e.text for e in entries] == ["one", "two"]
    assert len(problems) == 1 and problems[0].line == 3 and "cut short" in problems[0].why
    write(tmp_path, "three")  # a new root: the torn row is closed off, not overwritten
    entries, problems = read_incident(path)
    assert [(e.seq, e.text) for e in entries] == [(1, "one"), (2, "two"), (3, "three")]
    assert [p.line for p in problems] == [3] and problems[0].offset == \
        len(path.read_bytes().split(b"\n")[0]) + len(path.read_bytes().split(b"\n")[1]) + 2


def test_a_damaged_file_exports_its_good_rows_and_names_each_bad_line(tmp_path: Path) -> None:
    write(tmp_path, "before")
    path = incident_file(tmp_path)
    with path.open("ab") as f:
        f.write(b"garbage\n")
        f.write(b'{"seq":9,"ts":2.0,"kind":"meteor","text":"x"}\n')
    write(tmp_path, "after")
    entries, problems = read_incident(path)
    assert [e.text for e in entries] == ["before", "after"]
    assert [(p.line, p.offset) for p in problems] == [
        (2, len(path.read_bytes().split(b"\n")[0]) + 1),
        (3, sum(len(x) + 1 for x in path.read_bytes().split(b"\n")[:2]))]
    assert "not JSON" in problems[0].why and "'meteor' is not one of" in problems[1].why
    proc = subprocess.run([sys.executable, "-m", "mrss", "incident", "export", str(tmp_path),
                           "--format", "md"], capture_output=True, text=True, timeout=60)
    assert proc.returncode == 1
    assert "before" in proc.stdout and "after" in proc.stdout  # nothing good lost
    assert f"{path}:2: (byte " in proc.stderr and f"{path}:3: (byte " in proc.stderr
    assert "Damaged lines" in proc.stdout


def test_export_of_a_place_without_a_record_is_a_clear_error(tmp_path: Path) -> None:
    proc = subprocess.run([sys.executable, "-m", "mrss", "incident", "export", str(tmp_path)],
                          capture_output=True, text=True, timeout=60)
    assert proc.returncode == 2
    assert "neither a run dir with incident.jsonl nor a project" in proc.stderr
