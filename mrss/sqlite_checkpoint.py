"""The components' SQLite files in WAL mode: how one is opened (`connect_wal`), and its
checkpoints on a thread of their own, off the writers' path.

SQLite in WAL mode copies the log back into the database file every 1,000 pages by
default, in whichever commit crosses that mark, and syncs the file while doing so: that
commit takes milliseconds (tens on a busy disk) instead of tens of microseconds. The
action journal and the world model write on latency-critical paths, so they turn the
automatic checkpoint off (`PRAGMA wal_autocheckpoint=0` on their connection) and let a
`Checkpointer` run a PASSIVE checkpoint every `interval` seconds on its own connection:
it never waits for, nor blocks, the writer, and the log stays bounded.

A checkpoint that copies the whole log back lets the next commit start the log over
from its beginning, and that commit syncs the log's new header (SQLite does so at
`synchronous=NORMAL`): one sync per restart, on the writer's path after all. On a disk
that other writers keep busy (the world model's telemetry) such a sync took 0.2-400 ms,
and a journal commit 267 ms with it. So the writers on the action path (the journal, the
percept ledger) checkpoint every `RARE_INTERVAL` seconds: a tenth of the restarts, for a
log of a few megabytes at most between two. The world model, which writes far more,
keeps `DEFAULT_INTERVAL`.
"""

from __future__ import annotations

import logging
import sqlite3
import threading
from pathlib import Path

log = logging.getLogger("mrss.sqlite")


def connect_wal(path: str | Path, *, durable: bool = False) -> sqlite3.Connection:
    """A connection to the SQLite file at `path` (its folder made if missing), shared by
    the threads of one component behind its own lock, in autocommit mode, with WAL and
    `synchronous=NORMAL` (survives a killed process, not a power cut) or, `durable`,
    FULL (every commit synced)."""
    Path(path).parent.mkdir(parents=True, exist_ok=True)
    db = sqlite3.connect(str(path), check_same_thread=False, isolation_level=None)
    db.execute("PRAGMA journal_mode=WAL")
    db.execute(f"PRAGMA synchronous={'FULL' if durable else 'NORMAL'}")
    return db

DEFAULT_INTERVAL = 1.0
RARE_INTERVAL = 10.0  # for writers on the action path: see the module docstring


class Checkpointer:
    """Checkpoints the WAL of the database at `path` every `interval` s until `close()`."""

    def __init__(self, path: str | Path, interval: float = DEFAULT_INTERVAL) -> None:
        self.path = str(path)
        self.interval = interval
        self.checkpoints = 0
        self._stop = threading.Event()
        self._thread = threading.Thread(target=self._run, name="sqlite-checkpoint",
                                        daemon=True)
        self._thread.start()

    def _run(self) -> None:
        db: sqlite3.Connection | None = None
        try:
            while not self._stop.wait(self.interval):
                try:
                    if db is None:
                        db = sqlite3.connect(self.path, check_same_thread=False,
                                             isolation_level=None, timeout=0.0)
                    db.execute("PRAGMA wal_checkpoint(PASSIVE)").fetchone()
                    self.checkpoints += 1
                except sqlite3.Error as exc:  # busy or gone: the next round tries again
                    log.debug("checkpoint of %s skipped: %s", self.path, exc)
        finally:
            if db is not None:
                db.close()

    def close(self) -> None:
        self._stop.set()
        self._thread.join(timeout=5)


def manual_checkpoints(db: sqlite3.Connection, path: str | Path,
                       interval: float = DEFAULT_INTERVAL) -> Checkpointer:
    """Turn `db`'s automatic checkpoints off and start a `Checkpointer` for `path`."""
    db.execute("PRAGMA wal_autocheckpoint=0")
    return Checkpointer(path, interval)
