"""The incident record as the dashboard sees it: read from the run dir, not the bus.

A dashboard that attaches late, or after a restart, has missed the bus traffic of the
mission so far; the root kept it (`incident.jsonl`, `mrss.runtime.incident_recorder`).
`IncidentFeed` reads the whole record on attach -- its rows go into the log pane, marked
`incident`, so the operator sees what happened before -- and reads the rows written
since at each tick, so `entries` is always the full record. A damaged line is a note
with its line number, never the end of the record.
"""

from __future__ import annotations

import logging
import time
from pathlib import Path

from rich.text import Text

from mrss.bus import BusEndpoints
from mrss.incident.entries import Entry, IncidentFileError, Level
from mrss.incident.journal import IncidentReader, incident_file
from mrss.tui.mission import run_dir_of
from mrss.tui.models.logfilter import LogEntry

LEVELS = {Level.INFO: (logging.INFO, ""), Level.WARNING: (logging.WARNING, "yellow"),
          Level.ALERT: (logging.ERROR, "bold red")}
ATTACH_LINES = 300  # rows of the record put in the log pane on attach
SOURCE = "incident"  # the log pane's component for rows from the record (`@incident`)


def line_of(entry: Entry) -> LogEntry:
    """A row of the record as a log pane line."""
    level, style = LEVELS[entry.level]
    stamp = time.strftime("%H:%M:%S", time.localtime(entry.ts))
    who = f" (by {entry.who})" if entry.who else ""
    return LogEntry(Text.assemble((f"{stamp} ", "dim"), (f"{entry.kind.value} ", "magenta"),
                                  (entry.text + who, style)), level, SOURCE)


class IncidentFeed:
    """The run's incident record, read on attach and followed."""

    def __init__(self, path: Path | None) -> None:
        self.path = path
        self.entries: list[Entry] = []
        self._reader = IncidentReader(path) if path is not None else None

    @classmethod
    def for_endpoints(cls, endpoints: BusEndpoints) -> IncidentFeed:
        run_dir = run_dir_of(endpoints.backend)
        return cls(incident_file(run_dir) if run_dir is not None else None)

    @property
    def problems(self) -> list[IncidentFileError]:
        return self._reader.problems if self._reader is not None else []

    def poll(self) -> list[Entry]:
        """The rows written since the last poll (all of them, the first time)."""
        if self._reader is None:
            return []
        fresh = self._reader.read_new()
        self.entries.extend(fresh)
        return fresh

    def attach_lines(self) -> list[LogEntry]:
        """The record so far, for the log pane: a line counting the earlier rows, then
        the newest `ATTACH_LINES` (each costs the pane ~0.3 ms to draw); `entries` holds
        them all."""
        rows = self.poll()
        lines = [line_of(e) for e in rows[-ATTACH_LINES:]]
        if len(rows) > ATTACH_LINES:
            since = time.strftime("%H:%M:%S", time.localtime(rows[0].ts))
            lines.insert(0, LogEntry(Text(
                f"incident record: {len(rows)} rows since {since}, the newest "
                f"{ATTACH_LINES} below (all of them: `mrss incident export`)",
                style="magenta"), logging.INFO, SOURCE))
        if self.problems:
            lines.append(LogEntry(Text(f"incident record: {len(self.problems)} damaged "
                                       f"line(s) left out, first: {self.problems[0]}",
                                       style="bold red"), logging.ERROR, SOURCE))
        return lines
