"""The reasoner's percept ledger: the percepts it stands on, kept across its restarts.

Percepts are mission state: an operator's area goal, a detected hotspot, a low battery
are facts about the world that must not vanish because the reasoner process did. The
ledger holds every percept the agent currently perceives, durably (SQLite, WAL):

- a percept is written here when it arrives, before the reliable channel acknowledges
  it (so one the sender no longer repeats is never only in memory);
- it leaves when its source removes it, or when the agent's own plans remove it
  (`-area_goal_received(G, _)[source(percept)]`: the goal was dealt with);
- a new incarnation of the reasoner asserts every standing percept again, in arrival
  order, before it hears new ones: its intentions are re-derived from them
  (level-triggered, like a controller reconciling declared state).

The ledger also remembers the envelope ids of the last `ID_MEMORY` percepts it took
(`take`): a percept sent again under the same id (a redelivery: the events manager
died after the reasoner had it but before the MQTT broker heard so, and the broker
delivered the event again to its next incarnation, whose percepts repeat the ids) is
acknowledged and not acted on again, across restarts of the reasoner too.

The first incarnation of a run starts with an empty ledger. Literals are keyed without
their annotations, the way the belief base tells two beliefs apart.
"""

from __future__ import annotations

import threading
from pathlib import Path

from mrss.agentspeak import Struct, parse_literal, term_str
from mrss.sqlite_checkpoint import RARE_INTERVAL, connect_wal, manual_checkpoints

_SCHEMA = """
CREATE TABLE IF NOT EXISTS percepts (
    key TEXT PRIMARY KEY, literal TEXT NOT NULL, seq INTEGER NOT NULL
);
CREATE TABLE IF NOT EXISTS taken (id TEXT PRIMARY KEY, seq INTEGER NOT NULL);
CREATE INDEX IF NOT EXISTS taken_seq ON taken (seq);
"""
ID_MEMORY = 65536  # envelope ids of taken percepts remembered (the oldest forgotten)
_PRUNE_EVERY = 1024


def percept_key(literal: str | Struct) -> str:
    """The identity of a percept: its text without annotations (`hs(h1,3)`)."""
    lit = parse_literal(literal) if isinstance(literal, str) else literal
    return term_str(Struct(lit.functor, lit.args, (), lit.neg))


class PerceptLedger:
    """The standing percepts of one reasoner; thread-safe (one connection, one lock)."""

    def __init__(self, path: str | Path, *, fresh: bool = False) -> None:
        self.path = Path(path)
        self._lock = threading.Lock()
        self._db = connect_wal(self.path)  # survives a killed process
        self._db.executescript(_SCHEMA)
        # Checkpoints sync the file: on a thread of their own, not as a percept arrives.
        self._checkpointer = manual_checkpoints(self._db, self.path, RARE_INTERVAL)
        if fresh:
            self._db.execute("DELETE FROM percepts")
            self._db.execute("DELETE FROM taken")
        row = self._db.execute("SELECT COALESCE(MAX(seq), 0) FROM percepts").fetchone()
        self._seq = int(row[0])
        row = self._db.execute("SELECT COALESCE(MAX(seq), 0) FROM taken").fetchone()
        self._taken = int(row[0])

    def take(self, msg_id: str, op: str, literal: str, parsed: Struct | None = None) -> bool:
        """Take the percept of envelope `msg_id` (`op` "add" or "remove"): False, and
        nothing changes, if that id was taken before; else the id is remembered and the
        percept added or removed, in one transaction."""
        key = percept_key(literal if parsed is None else parsed)
        with self._lock:
            self._db.execute("BEGIN IMMEDIATE")
            try:
                if self._db.execute("SELECT 1 FROM taken WHERE id=?", (msg_id,)).fetchone():
                    self._db.execute("ROLLBACK")
                    return False
                self._taken += 1
                self._db.execute("INSERT INTO taken VALUES (?,?)", (msg_id, self._taken))
                if op == "add":
                    self._seq += 1
                    self._db.execute("INSERT INTO percepts VALUES (?,?,?) ON CONFLICT(key) DO "
                                     "UPDATE SET literal=excluded.literal",
                                     (key, literal, self._seq))
                else:
                    self._db.execute("DELETE FROM percepts WHERE key=?", (key,))
                if self._taken % _PRUNE_EVERY == 0:
                    self._db.execute("DELETE FROM taken WHERE seq<=?",
                                     (self._taken - ID_MEMORY,))
                self._db.execute("COMMIT")
            except BaseException:
                self._db.execute("ROLLBACK")
                raise
            return True

    def add(self, literal: str, parsed: Struct | None = None) -> None:
        """The agent perceives `literal` (a repeat keeps its first place); `parsed`, the
        same literal already read, saves reading it again."""
        key = percept_key(literal if parsed is None else parsed)
        with self._lock:
            self._seq += 1
            self._db.execute("INSERT INTO percepts VALUES (?,?,?) ON CONFLICT(key) DO "
                             "UPDATE SET literal=excluded.literal", (key, literal, self._seq))

    def remove(self, literal: str | Struct) -> None:
        """The agent no longer perceives `literal` (absent: nothing happens)."""
        key = percept_key(literal)
        with self._lock:
            self._db.execute("DELETE FROM percepts WHERE key=?", (key,))

    def standing(self) -> list[str]:
        """Every standing percept, oldest first."""
        with self._lock:
            rows = self._db.execute("SELECT literal FROM percepts ORDER BY seq").fetchall()
        return [r[0] for r in rows]

    def __len__(self) -> int:
        with self._lock:
            return int(self._db.execute("SELECT COUNT(*) FROM percepts").fetchone()[0])

    def close(self) -> None:
        self._checkpointer.close()
        with self._lock:
            self._db.close()
