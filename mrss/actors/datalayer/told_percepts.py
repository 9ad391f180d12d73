"""What the geofence has told the agent, per robot, kept across data layer restarts.

The geofence's percepts are mission state: `geofence_exit(rover1, salt_marsh, ...)` holds
work back until the rover is out. The reasoner keeps them (its percept ledger) when the
data layer process dies; so the data layer must know, after a restart, what its previous
incarnation told, or it never takes it back. This store (SQLite, WAL, in the run folder)
holds one row per (robot, literal):

- `held`: written *before* the percept is added, so the agent never holds a percept the
  store does not know (a kill between the two leaves a row for a percept that never
  arrived: taking it back later is harmless, the reasoner ignores removing what it
  does not hold);
- `withdrawn`: written before the percept is removed; the row stays until every percept
  sent so far is acknowledged (`forget_withdrawn`), since a removal still unacknowledged
  when the process dies is lost with it (the reliable channel keeps messages in memory).
  A new incarnation sends these removals again at its start.

The first incarnation of a run starts with an empty store (`fresh`).
"""

from __future__ import annotations

import sqlite3
import threading
from enum import StrEnum
from pathlib import Path

from mrss.sqlite_checkpoint import RARE_INTERVAL, Checkpointer, manual_checkpoints

_SCHEMA = """
CREATE TABLE IF NOT EXISTS told (
    robot TEXT NOT NULL, literal TEXT NOT NULL, state TEXT NOT NULL,
    PRIMARY KEY (robot, literal)
);
"""


class Told(StrEnum):
    """Where a told percept stands."""

    HELD = "held"            # added (or about to be): the agent may hold it
    WITHDRAWN = "withdrawn"  # removed (or about to be), the removal maybe not yet arrived


class ToldPercepts:
    """The geofence's told percepts; thread-safe (one connection, one lock). `path`
    ":memory:" keeps them in memory only (no restart to survive)."""

    def __init__(self, path: str | Path, *, fresh: bool = False) -> None:
        self.path = str(path)
        if self.path != ":memory:":
            Path(self.path).parent.mkdir(parents=True, exist_ok=True)
        self._lock = threading.Lock()
        self._db = sqlite3.connect(self.path, check_same_thread=False, isolation_level=None)
        self._checkpointer: Checkpointer | None = None
        if self.path != ":memory:":
            self._db.execute("PRAGMA journal_mode=WAL")
            self._db.execute("PRAGMA synchronous=NORMAL")  # survives a killed process
            self._checkpointer = manual_checkpoints(self._db, self.path, RARE_INTERVAL)
        self._db.executescript(_SCHEMA)
        if fresh:
            self._db.execute("DELETE FROM told")

    def mark(self, robot: str, literal: str, state: Told) -> None:
        """`literal` about `robot` is about to be added (HELD) or removed (WITHDRAWN)."""
        with self._lock:
            self._db.execute("INSERT INTO told VALUES (?,?,?) ON CONFLICT(robot, literal) "
                             "DO UPDATE SET state=excluded.state",
                             (robot, literal, state.value))

    def rows(self, state: Told) -> list[tuple[str, str]]:
        """(robot, literal) of every row in `state`."""
        with self._lock:
            return [(r, lit) for r, lit in self._db.execute(
                "SELECT robot, literal FROM told WHERE state=? ORDER BY robot, literal",
                (state.value,))]

    def forget_withdrawn(self) -> int:
        """Drop the withdrawn rows (their removals are acknowledged); how many."""
        with self._lock:
            return self._db.execute("DELETE FROM told WHERE state=?",
                                    (Told.WITHDRAWN.value,)).rowcount

    def close(self) -> None:
        if self._checkpointer is not None:
            self._checkpointer.close()
        with self._lock:
            self._db.close()
