"""WAL checkpoints on their own thread: writers never checkpoint, the log stays bounded."""

from __future__ import annotations

import sqlite3
from pathlib import Path

from mrss.sqlite_checkpoint import manual_checkpoints
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
