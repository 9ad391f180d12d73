"""The incident file: append-only JSON lines in the run dir, and how it is read back.

`IncidentJournal` appends one row a line and hands each line to the OS at once (a
component or the root killed with SIGKILL loses nothing written before). A root started
again on the same run dir appends to the same file, numbering on from its last row; a
line cut short by a crash stays where it is (closed with a newline, so the next row
starts clean) and is reported by the reader, never overwritten.

`IncidentReader` reads the file from the start or from where it stopped (a dashboard
polls it for new rows): every good row is kept, and every bad line is an
`IncidentFileError` with its line number and byte offset, so a damaged file loses
nothing of its good part.
"""

from __future__ import annotations

import json
import os
import threading
from dataclasses import replace
from pathlib import Path

from mrss.incident.entries import Entry, IncidentFileError

FILE_NAME = "incident.jsonl"


def incident_file(run_dir: Path) -> Path:
    """Where a run dir keeps its incident record."""
    return run_dir / FILE_NAME


class IncidentReader:
    """Reads an incident file's complete lines, from where the last read stopped."""

    def __init__(self, path: Path) -> None:
        self.path = path
        self.offset = 0  # bytes consumed: complete lines only
        self.line = 0  # lines consumed
        self.problems: list[IncidentFileError] = []

    def read_new(self) -> list[Entry]:
        """The good rows of the complete lines written since the last read (none if the
        file does not exist yet); bad lines are appended to `problems`."""
        try:
            with open(self.path, "rb") as f:
                f.seek(self.offset)
                data = f.read()
        except FileNotFoundError:
            return []
        return self.take(data)

    def take(self, data: bytes) -> list[Entry]:
        """The good rows of the complete lines of `data` (the file's bytes from
        `offset` on); what follows the last newline is left for the next read."""
        end = data.rfind(b"\n") + 1
        entries: list[Entry] = []
        start = 0
        while start < end:
            stop = data.index(b"\n", start)
            self.line += 1
            raw = data[start:stop]
            if raw.strip():
                entry = self._decode(raw, self.offset + start)
                if entry is not None:
                    entries.append(entry)
            start = stop + 1
        self.offset += end
        return entries

    def trailing(self) -> int:
        """Bytes after the last complete line (a row being written, or cut short)."""
        try:
            return max(0, self.path.stat().st_size - self.offset)
        except FileNotFoundError:
            return 0

    def _decode(self, raw: bytes, offset: int) -> Entry | None:
        try:
            return Entry.from_row(json.loads(raw))
        except (ValueError, UnicodeDecodeError) as exc:
            why = exc.msg if isinstance(exc, json.JSONDecodeError) else str(exc)
            if isinstance(exc, json.JSONDecodeError):
                why = f"not JSON: {why} (column {exc.colno})"
            self.problems.append(IncidentFileError(str(self.path), self.line, offset, why))
            return None


def read_incident(path: Path) -> tuple[list[Entry], list[IncidentFileError]]:
    """Every good row of a whole file, and what was wrong with the other lines (a last
    line without its newline included: a row cut short). The file is read once, so a
    row appended meanwhile is either wholly in or out (a second read for the last line
    once took a row being written after it for part of it). A record still being
    written is read with `IncidentReader`, whose rows are the complete lines."""
    if not path.exists():
        raise FileNotFoundError(f"{path}: no incident record here")
    with open(path, "rb") as f:
        data = f.read()
    reader = IncidentReader(path)
    entries = reader.take(data)
    tail = data[reader.offset:]
    if tail:
        reader.line += 1
        entry = reader._decode(tail, reader.offset)  # a complete row lacking its newline
        if entry is not None:
            entries.append(entry)
        else:
            last = reader.problems.pop()
            reader.problems.append(IncidentFileError(
                last.file, last.line, last.offset,
                f"cut short ({len(tail)} bytes): {last.why}"))
    return entries, reader.problems


class IncidentJournal:
    """Appends rows to one incident file; thread-safe (the bus thread and the
    supervisor's thread both write)."""

    def __init__(self, path: Path) -> None:
        self.path = path
        self._lock = threading.Lock()
        path.parent.mkdir(parents=True, exist_ok=True)
        self.seq = self._last_seq()
        self._fd = os.open(path, os.O_WRONLY | os.O_APPEND | os.O_CREAT, 0o640)
        if path.stat().st_size and not self._ends_with_newline():
            os.write(self._fd, b"\n")  # a row cut short stays one bad line, alone

    def _last_seq(self) -> int:
        if not self.path.exists():
            return 0
        entries, _ = read_incident(self.path)
        return max((e.seq for e in entries), default=0)

    def _ends_with_newline(self) -> bool:
        with open(self.path, "rb") as f:
            f.seek(-1, os.SEEK_END)
            return f.read(1) == b"\n"

    def append(self, entry: Entry) -> Entry:
        """Number the row, write it as one line; the numbered row."""
        with self._lock:
            self.seq += 1
            numbered = replace(entry, seq=self.seq)
            os.write(self._fd, numbered.to_json().encode() + b"\n")
            return numbered

    def sync(self) -> None:
        """To the disk, not just the OS (the host may lose power)."""
        with self._lock:
            os.fsync(self._fd)

    def close(self) -> None:
        with self._lock:
            if self._fd >= 0:
                os.close(self._fd)
                self._fd = -1
