"""WAL checkpoints on their own thread: writers never checkpoint, the log stays bounded."""

from __future__ import annotations

import sqlite3
import time
from pathlib import Path

from mrss.actors.rcl.journal import ActionJournal
from mrss.actors.reasoner.percept_ledger import PerceptLedger
from mrss.api import Action
from mrss.sqlite_checkpoint import DEFAULT_INTERVAL, RARE_INTERVAL, manual_checkpoints
from mrss.testing import wait_until


def test_checkpoints_leave_the_writer_and_keep_the_log_bounded(tmp_path: Path) -> None:
    path = tmp_path / "db.sqlite"
    wal = tmp_path / "db.sqlite-wal"
    db = sqlite3.connect(str(path), isolation_level=None, check_same_thread=False)
    db.execute("PRAGMA journal_mode=WAL")
    db.execute("CREATE TABLE t (x INTEGER, pad TEXT)")
    checkpointer = manual_checkpoints(db, path, interval=0.05)
    try:
        assert db.execute("PRAGMA wal_autocheckpoint").fetchone() == (0,)

        def write_batch(start: int) -> None:  # one transaction per row, as the journal
            for i in range(start, start + 600):
                db.execute("INSERT INTO t VALUES (?, ?)", (i, "x" * 200))

        write_batch(0)
        first = wal.stat().st_size
        seen = checkpointer.checkpoints
        wait_until(lambda: checkpointer.checkpoints >= seen + 2, timeout=10,
                   message="a checkpoint after the first batch")
        write_batch(600)
        # The log was copied into the database, so the second batch rewound it instead
        # of doubling it (with no checkpoint at all it would hold both batches).
        assert wal.stat().st_size <= first * 1.2
    finally:
        checkpointer.close()
        db.close()
    check = sqlite3.connect(str(path))
    assert check.execute("SELECT count(*) FROM t").fetchone() == (1200,)
    check.close()


def _log_salt(wal: Path) -> bytes:
    """The WAL header's salt: SQLite draws a new one each time the log starts over."""
    return wal.read_bytes()[16:24]


def test_the_action_paths_writers_start_their_log_over_rarely(tmp_path: Path) -> None:
    # A log that starts over costs the next commit a sync of its header (the module
    # docstring): the journal and the percept ledger, whose commits are on the action
    # path, checkpoint every RARE_INTERVAL, so 2.5 s of writing (which the default
    # 1 s checkpoints would restart twice) keeps one log throughout.
    journal = ActionJournal(tmp_path / "journal.sqlite3")
    ledger = PerceptLedger(tmp_path / "ledger.sqlite3", fresh=True)
    logs = [tmp_path / "journal.sqlite3-wal", tmp_path / "ledger.sqlite3-wal"]
    try:
        action = Action(uuid="a", name="cover", robot="uav1")
        journal.record(action)
        ledger.add("hotspot(h0)")
        first = [_log_salt(wal) for wal in logs]
        deadline = time.monotonic() + 2.5
        n = 0
        while time.monotonic() < deadline:  # a write every 10 ms, as a busy mission
            n += 1
            action.progress = {"n": n}
            journal.record(action)
            ledger.add(f"hotspot(h{n})")
            time.sleep(0.01)  # pacing the writes, not waiting for a condition
        assert [_log_salt(wal) for wal in logs] == first
        assert RARE_INTERVAL > 2.5 >= 2 * DEFAULT_INTERVAL
    finally:
        journal.close()
        ledger.close()
