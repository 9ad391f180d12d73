"""The action journal: every action transition, committed to SQLite before it is published.

A restarted RCL reads it back (`open_actions`) so that no non-terminal action is
forgotten, and checks it (`get`) to stay idempotent for requests it has already seen.
WAL mode; by default `synchronous=NORMAL`, which survives a killed process (the
failure we guard against) but not a power cut; `durable=True` syncs every commit.
"""

from __future__ import annotations

import json
import sqlite3
import threading
import time
from pathlib import Path
from typing import Any, NamedTuple

from mrss.api import Action
from mrss.messages import ActionState

_SCHEMA = """
CREATE TABLE IF NOT EXISTS actions (
    uuid TEXT PRIMARY KEY, name TEXT NOT NULL, args TEXT NOT NULL, robot TEXT NOT NULL,
    goal TEXT NOT NULL, priority INTEGER NOT NULL, literal TEXT NOT NULL, state TEXT NOT NULL,
    reason TEXT NOT NULL, progress TEXT NOT NULL, suspended_by TEXT NOT NULL,
    created REAL NOT NULL, updated REAL NOT NULL,
    requester TEXT NOT NULL, requester_inc INTEGER NOT NULL
);
CREATE INDEX IF NOT EXISTS actions_state ON actions(state);
CREATE TABLE IF NOT EXISTS transitions (
    seq INTEGER PRIMARY KEY AUTOINCREMENT, uuid TEXT NOT NULL, state TEXT NOT NULL,
    reason TEXT NOT NULL, progress TEXT NOT NULL, ts REAL NOT NULL
);
CREATE INDEX IF NOT EXISTS transitions_uuid ON transitions(uuid);
CREATE TABLE IF NOT EXISTS robots (robot TEXT PRIMARY KEY, teleop INTEGER NOT NULL);
"""

_TERMINAL = tuple(s.value for s in ActionState if s.terminal)


class Requester(NamedTuple):
    """Who asked for an action: the sending component and its incarnation."""

    src: str = ""
    inc: int = 0


NOBODY = Requester()


class JournalEntry(NamedTuple):
    """An action as last journaled, why it is suspended ("" if not), who asked for it."""

    action: Action
    suspended_by: str
    requester: Requester


class ActionJournal:
    """SQLite record of actions; thread-safe (one connection behind a lock)."""

    def __init__(self, path: str | Path, *, durable: bool = False) -> None:
        self.path = Path(path)
        self.path.parent.mkdir(parents=True, exist_ok=True)
        self._lock = threading.Lock()
        self._db = sqlite3.connect(str(self.path), check_same_thread=False,
                                   isolation_level=None)
        self._db.execute("PRAGMA journal_mode=WAL")
        self._db.execute(f"PRAGMA synchronous={'FULL' if durable else 'NORMAL'}")
        self._db.executescript(_SCHEMA)

    def close(self) -> None:
        with self._lock:
            self._db.close()

    def record(self, action: Action, suspended_by: str = "",
               requester: Requester = NOBODY) -> int:
        """Write the action's current state as a transition and commit; returns its seq.

        `requester` is stored when the action is first recorded.
        """
        now = time.time()
        progress = json.dumps(action.progress)
        with self._lock:
            self._db.execute("BEGIN IMMEDIATE")
            try:
                self._db.execute(
                    "INSERT INTO actions VALUES (?,?,?,?,?,?,?,?,?,?,?,?,?,?,?) "
                    "ON CONFLICT(uuid) DO UPDATE SET state=excluded.state, "
                    "reason=excluded.reason, progress=excluded.progress, "
                    "suspended_by=excluded.suspended_by, updated=excluded.updated",
                    (action.uuid, action.name, json.dumps(action.args), action.robot,
                     action.goal, action.priority, action.literal, action.state.value,
                     action.reason, progress, suspended_by, now, now, requester.src,
                     requester.inc))
                cur = self._db.execute(
                    "INSERT INTO transitions (uuid, state, reason, progress, ts) "
                    "VALUES (?,?,?,?,?)",
                    (action.uuid, action.state.value, action.reason, progress, now))
                self._db.execute("COMMIT")
            except BaseException:
                self._db.execute("ROLLBACK")
                raise
        return int(cur.lastrowid or 0)

    def save_progress(self, uuid: str, progress: dict[str, Any]) -> None:
        """Store an action's progress (not a transition: nothing is published)."""
        with self._lock:
            self._db.execute("UPDATE actions SET progress=?, updated=? WHERE uuid=?",
                             (json.dumps(progress), time.time(), uuid))

    def get(self, uuid: str) -> JournalEntry | None:
        with self._lock:
            row = self._db.execute("SELECT * FROM actions WHERE uuid=?", (uuid,)).fetchone()
        return _entry(row) if row else None

    def open_actions(self) -> list[JournalEntry]:
        """Every non-terminal action, oldest first."""
        marks = ",".join("?" * len(_TERMINAL))
        with self._lock:
            rows = self._db.execute(
                f"SELECT * FROM actions WHERE state NOT IN ({marks}) ORDER BY created, rowid",
                _TERMINAL).fetchall()
        return [_entry(r) for r in rows]

    def transitions(self, uuid: str) -> list[tuple[ActionState, str]]:
        """The journaled (state, reason) sequence of one action, in order."""
        with self._lock:
            rows = self._db.execute(
                "SELECT state, reason FROM transitions WHERE uuid=? ORDER BY seq",
                (uuid,)).fetchall()
        return [(ActionState(s), r) for s, r in rows]

    def incarnations(self) -> dict[str, int]:
        """The newest incarnation of each requester that ever sent an action."""
        with self._lock:
            rows = self._db.execute("SELECT requester, MAX(requester_inc) FROM actions "
                                    "WHERE requester != '' GROUP BY requester").fetchall()
        return {src: int(inc) for src, inc in rows}

    def set_teleop(self, robot: str, on: bool) -> None:
        with self._lock:
            self._db.execute("INSERT INTO robots VALUES (?,?) ON CONFLICT(robot) "
                             "DO UPDATE SET teleop=excluded.teleop", (robot, int(on)))

    def teleop_robots(self) -> set[str]:
        with self._lock:
            rows = self._db.execute("SELECT robot FROM robots WHERE teleop=1").fetchall()
        return {r[0] for r in rows}


def _entry(row: tuple[Any, ...]) -> JournalEntry:
    (uuid, name, args, robot, goal, priority, literal, state, reason, progress,
     suspended_by, _created, _updated, requester, requester_inc) = row
    action = Action(uuid=uuid, name=name, args=json.loads(args), robot=robot, goal=goal,
                    priority=priority, state=ActionState(state), progress=json.loads(progress),
                    literal=literal, reason=reason)
    return JournalEntry(action, suspended_by, Requester(requester, requester_inc))
