"""The action journal: every action transition, committed to SQLite before it is published.

A restarted RCL reads it back (`open_actions`) so that no non-terminal action is
forgotten, and checks it (`get`) to stay idempotent for requests it has already seen.
WAL mode; by default `synchronous=NORMAL`, which survives a killed process (the
failure we guard against) but not a power cut; `durable=True` syncs every commit. WAL
checkpoints (which sync the file) run on a thread of their own (`mrss.sqlite_checkpoint`),
not in whichever transition crosses SQLite's mark.

It also holds the tasks addressed to a role (mrss.actors.rcl.allocation.book): each
one's request, who holds it now ("" while it waits) and the robots that lost it; an
award is committed before the action on the winner is, so a restart carries out a
recorded award instead of deciding again. And, per robot, whether it is in teleop and
whether the operator took it out of service (both survive any restart). And the
controls not yet applied by a robot actor (mrss.actors.rcl.controls).
It stays bounded: `compact` drops the terminal actions (and their transitions) last
updated more than `keep_seconds` ago, except the newest `keep_last` of them, which the
dashboard's history shows; and the pending controls of actions no longer open. The RCL
compacts at start and on a timer. A uuid compacted away is forgotten: a request
repeating it after that is a new action. What compaction removed is kept in one row
(`compaction`: how many actions in all, and the watermark `before`, the latest cutoff:
no terminal action last updated before it is left), so a reader of the journal (the
chaos checker) can tell an action compacted away from one never journaled.

One idea in one module: the RCL's one durable record, one SQLite file whose tables are
written together in single transactions (an award with its action, a task with its
waiting action); split by table, a reader would lose what commits with what.
"""

from __future__ import annotations

import json
import logging
import sqlite3
import threading
import time
from collections.abc import Callable
from pathlib import Path
from typing import Any, NamedTuple

from mrss.actors.rcl.action import Action
from mrss.messages import ActionState
from mrss.sqlite_checkpoint import RARE_INTERVAL, connect_wal, manual_checkpoints

log = logging.getLogger("mrss.rcl.journal")

_SCHEMA = """
CREATE TABLE IF NOT EXISTS actions (
    uuid TEXT PRIMARY KEY, name TEXT NOT NULL, args TEXT NOT NULL, robot TEXT NOT NULL,
    goal TEXT NOT NULL, priority INTEGER NOT NULL, literal TEXT NOT NULL, state TEXT NOT NULL,
    reason TEXT NOT NULL, progress TEXT NOT NULL, suspended_by TEXT NOT NULL,
    created REAL NOT NULL, updated REAL NOT NULL,
    requester TEXT NOT NULL, requester_inc INTEGER NOT NULL,
    cause TEXT NOT NULL DEFAULT ''
);
CREATE INDEX IF NOT EXISTS actions_state ON actions(state);
CREATE TABLE IF NOT EXISTS transitions (
    seq INTEGER PRIMARY KEY AUTOINCREMENT, uuid TEXT NOT NULL, state TEXT NOT NULL,
    reason TEXT NOT NULL, progress TEXT NOT NULL, ts REAL NOT NULL
);
CREATE INDEX IF NOT EXISTS transitions_uuid ON transitions(uuid);
CREATE TABLE IF NOT EXISTS robots (robot TEXT PRIMARY KEY, teleop INTEGER NOT NULL,
                                   decommissioned INTEGER NOT NULL DEFAULT 0);
CREATE TABLE IF NOT EXISTS stand_downs (ident TEXT PRIMARY KEY, body TEXT NOT NULL);
CREATE TABLE IF NOT EXISTS controls (
    seq INTEGER PRIMARY KEY AUTOINCREMENT, robot TEXT NOT NULL, uuid TEXT NOT NULL,
    event TEXT NOT NULL, ts REAL NOT NULL
);
CREATE INDEX IF NOT EXISTS actions_updated ON actions(updated);
CREATE TABLE IF NOT EXISTS compaction (
    id INTEGER PRIMARY KEY CHECK (id = 1), dropped INTEGER NOT NULL, before REAL NOT NULL
);
CREATE TABLE IF NOT EXISTS tasks (
    uuid TEXT PRIMARY KEY, request TEXT NOT NULL, requester TEXT NOT NULL,
    requester_inc INTEGER NOT NULL, robot TEXT NOT NULL, lost TEXT NOT NULL,
    updated REAL NOT NULL
);
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


class TaskRow(NamedTuple):
    """A task addressed to a role as journaled: its request (the wire fields), requester,
    holder ("" while it waits) and the robots that lost it, oldest first."""

    uuid: str
    request: dict[str, Any]
    requester: Requester
    robot: str
    lost: list[str]


class ActionJournal:
    """SQLite record of actions; thread-safe (one connection behind a lock)."""

    def __init__(self, path: str | Path, *, durable: bool = False,
                 clock: Callable[[], float] = time.time, write_patience: float = 15.0) -> None:
        self.path = Path(path)
        self.write_patience = write_patience
        self.clock = clock  # wall-clock seconds (a benchmark simulates a day with it)
        self._lock = threading.Lock()
        self._db = connect_wal(self.path, durable=durable)
        self._db.executescript(_SCHEMA)
        # Checkpoints sync the file: on a thread of their own, never in a transition.
        self._checkpointer = manual_checkpoints(self._db, self.path, RARE_INTERVAL)
        columns = {row[1] for row in self._db.execute("PRAGMA table_info(actions)")}
        if "cause" not in columns:  # a journal kept from before failure causes existed
            self._db.execute("ALTER TABLE actions ADD COLUMN cause TEXT NOT NULL DEFAULT ''")
        columns = {row[1] for row in self._db.execute("PRAGMA table_info(robots)")}
        if "decommissioned" not in columns:  # kept from before decommissioning existed
            self._db.execute("ALTER TABLE robots ADD COLUMN decommissioned INTEGER NOT NULL "
                             "DEFAULT 0")

    def close(self) -> None:
        self._checkpointer.close()
        with self._lock:
            self._db.close()

    def record(self, action: Action, suspended_by: str = "",
               requester: Requester = NOBODY) -> int:
        """Write the action's current state as a transition and commit; returns its seq.

        `requester` is stored when the action is first recorded; its robot (and its
        arguments, the robot's id first) change when a task addressed to a role goes from
        a lost robot to another (mrss.actors.rcl.reallocation). A write the disk refuses
        (full, a file size limit) is tried again with backoff for `write_patience`
        seconds before the error is raised: nothing is published before it is journaled,
        so the caller simply waits for the disk.
        """
        deadline = time.monotonic() + self.write_patience
        delay = 0.05
        while True:
            try:
                return self._record(action, suspended_by, requester)
            except sqlite3.OperationalError as exc:
                if time.monotonic() + delay > deadline:
                    raise
                if delay == 0.05:
                    log.warning("journal %s: cannot write %s (%s); trying again for %.0fs",
                                self.path.name, action.uuid, exc, self.write_patience)
                time.sleep(delay)  # backoff while the disk is full
                delay = min(delay * 2, 1.0)

    def _record(self, action: Action, suspended_by: str, requester: Requester) -> int:
        now = self.clock()
        progress = json.dumps(action.progress)
        with self._lock:
            self._db.execute("BEGIN IMMEDIATE")
            try:
                self._db.execute(
                    "INSERT INTO actions VALUES (?,?,?,?,?,?,?,?,?,?,?,?,?,?,?,?) "
                    "ON CONFLICT(uuid) DO UPDATE SET state=excluded.state, "
                    "reason=excluded.reason, progress=excluded.progress, "
                    "suspended_by=excluded.suspended_by, updated=excluded.updated, "
                    "cause=excluded.cause, robot=excluded.robot, args=excluded.args",
                    (action.uuid, action.name, json.dumps(action.args), action.robot,
                     action.goal, action.priority, action.literal, action.state.value,
                     action.reason, progress, suspended_by, now, now, requester.src,
                     requester.inc, action.cause))
                cur = self._db.execute(
                    "INSERT INTO transitions (uuid, state, reason, progress, ts) "
                    "VALUES (?,?,?,?,?)",
                    (action.uuid, action.state.value, action.reason, progress, now))
                self._db.execute("COMMIT")
            except BaseException:
                if self._db.in_transaction:  # SQLite may have rolled back on its own
                    self._db.execute("ROLLBACK")
                raise
        return int(cur.lastrowid or 0)

    def save_progress(self, uuid: str, progress: dict[str, Any]) -> None:
        """Store an action's progress (not a transition: nothing is published)."""
        with self._lock:
            self._db.execute("UPDATE actions SET progress=?, updated=? WHERE uuid=?",
                             (json.dumps(progress), self.clock(), uuid))

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

    def adopt(self, uuid: str, requester: Requester) -> None:
        """A newer incarnation of the requester took the action over (it waits for it)."""
        with self._lock:
            self._db.execute("UPDATE actions SET requester=?, requester_inc=? WHERE uuid=?",
                             (requester.src, requester.inc, uuid))

    def left_by(self, src: str, below_inc: int, ended_since: float) -> list[JournalEntry]:
        """What incarnations of `src` older than `below_inc` left: their open actions, and
        those that ended after `ended_since` (wall-clock seconds), oldest first."""
        marks = ",".join("?" * len(_TERMINAL))
        with self._lock:
            rows = self._db.execute(
                f"SELECT * FROM actions WHERE requester=? AND requester_inc<? AND "
                f"(state NOT IN ({marks}) OR updated>=?) ORDER BY created, rowid",
                (src, below_inc, *_TERMINAL, ended_since)).fetchall()
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
            self._db.execute("INSERT INTO robots (robot, teleop) VALUES (?,?) ON CONFLICT(robot) "
                             "DO UPDATE SET teleop=excluded.teleop", (robot, int(on)))

    def teleop_robots(self) -> set[str]:
        with self._lock:
            rows = self._db.execute("SELECT robot FROM robots WHERE teleop=1").fetchall()
        return {r[0] for r in rows}

    def set_decommissioned(self, robot: str, out: bool) -> None:
        """The operator took `robot` out of service (`out`) or put it back."""
        with self._lock:
            self._db.execute("INSERT INTO robots (robot, teleop, decommissioned) "
                             "VALUES (?,0,?) ON CONFLICT(robot) "
                             "DO UPDATE SET decommissioned=excluded.decommissioned",
                             (robot, int(out)))

    def save_stand_down(self, ident: str, body: str) -> None:
        """An active stand-down by area (mrss.actors.rcl.stand_down), as JSON."""
        with self._lock:
            self._db.execute("INSERT OR REPLACE INTO stand_downs (ident, body) VALUES (?,?)",
                             (ident, body))

    def drop_stand_down(self, ident: str) -> None:
        with self._lock:
            self._db.execute("DELETE FROM stand_downs WHERE ident=?", (ident,))

    def stand_downs(self) -> dict[str, str]:
        with self._lock:
            return dict(self._db.execute("SELECT ident, body FROM stand_downs").fetchall())

    def decommissioned_robots(self) -> set[str]:
        with self._lock:
            rows = self._db.execute("SELECT robot FROM robots WHERE decommissioned=1").fetchall()
        return {r[0] for r in rows}


    # -- tasks addressed to a role (mrss.actors.rcl.allocation.book) --------------------------
    def open_task(self, action: Action, request: dict[str, Any], requester: Requester,
                  holder: str = "") -> bool:
        """Record a new task, waiting (or already held by `holder`: decided at once, the
        award in the same commit), with its action (on no robot yet: `action`), in one
        commit; False if its uuid is known already. The action's row is what a restarted
        requester finds in its inventory and adopts, and what a new run fails."""
        now = self.clock()
        with self._lock:
            self._db.execute("BEGIN IMMEDIATE")
            try:
                cur = self._db.execute(
                    "INSERT OR IGNORE INTO tasks VALUES (?,?,?,?,?,'[]',?)",
                    (action.uuid, json.dumps(request), requester.src, requester.inc,
                     holder, now))
                if cur.rowcount > 0:
                    self._db.execute(
                        "INSERT OR IGNORE INTO actions VALUES (?,?,?,?,?,?,?,?,?,?,?,?,?,?,?,?)",
                        (action.uuid, action.name, json.dumps(action.args), action.robot,
                         action.goal, action.priority, action.literal, action.state.value,
                         action.reason, json.dumps(action.progress), "", now, now,
                         requester.src, requester.inc, action.cause))
                    self._db.execute(
                        "INSERT INTO transitions (uuid, state, reason, progress, ts) "
                        "VALUES (?,?,?,?,?)", (action.uuid, action.state.value, action.reason,
                                               json.dumps(action.progress), now))
                self._db.execute("COMMIT")
            except BaseException:
                if self._db.in_transaction:
                    self._db.execute("ROLLBACK")
                raise
        return cur.rowcount > 0

    def hold_task(self, uuid: str, robot: str) -> None:
        """`robot` holds the task now ("": it waits again)."""
        with self._lock:
            self._db.execute("UPDATE tasks SET robot=?, updated=? WHERE uuid=?",
                             (robot, self.clock(), uuid))

    def lose_task(self, uuid: str, robot: str) -> None:
        """`robot` lost the task: it waits, and `robot` is added to those that lost it."""
        with self._lock:
            row = self._db.execute("SELECT lost FROM tasks WHERE uuid=?", (uuid,)).fetchone()
            lost = [*json.loads(row[0]), robot] if row else [robot]
            self._db.execute("UPDATE tasks SET robot='', lost=?, updated=? WHERE uuid=?",
                             (json.dumps(lost), self.clock(), uuid))

    def close_task(self, uuid: str) -> None:
        """The task's action ended (or it was rejected): it is no task any more."""
        with self._lock:
            self._db.execute("DELETE FROM tasks WHERE uuid=?", (uuid,))

    def tasks(self) -> list[TaskRow]:
        """Every task, oldest first."""
        with self._lock:
            rows = self._db.execute("SELECT uuid, request, requester, requester_inc, robot, "
                                    "lost FROM tasks ORDER BY rowid").fetchall()
        return [TaskRow(u, json.loads(r), Requester(s, i), robot, json.loads(lost))
                for u, r, s, i, robot, lost in rows]

    # -- pending controls (mrss.actors.rcl.controls) -------------------------------------------
    def add_control(self, robot: str, uuid: str, event: str) -> int:
        """Journal a control before it is told to the robot actor; returns its seq."""
        with self._lock:
            cur = self._db.execute("INSERT INTO controls (robot, uuid, event, ts) "
                                   "VALUES (?,?,?,?)", (robot, uuid, event, self.clock()))
        return int(cur.lastrowid or 0)

    def pending_controls(self, robot: str) -> list[tuple[int, str, str]]:
        """(seq, uuid, event) of every control for `robot` not yet applied, oldest first."""
        with self._lock:
            rows = self._db.execute("SELECT seq, uuid, event FROM controls WHERE robot=? "
                                    "ORDER BY seq", (robot,)).fetchall()
        return [(int(seq), str(uuid), str(event)) for seq, uuid, event in rows]

    def claim_control(self, seq: int) -> bool:
        """Mark a control applied; False if it was not pending (applied already)."""
        with self._lock:
            cur = self._db.execute("DELETE FROM controls WHERE seq=?", (seq,))
        return cur.rowcount > 0

    def drop_controls(self, robot: str | None = None) -> int:
        """Forget the pending controls of `robot` (of every robot with None)."""
        with self._lock:
            if robot is None:
                cur = self._db.execute("DELETE FROM controls")
            else:
                cur = self._db.execute("DELETE FROM controls WHERE robot=?", (robot,))
        return cur.rowcount

    # -- compaction ---------------------------------------------------------------------------
    def compact(self, keep_seconds: float, keep_last: int) -> int:
        """Drop terminal actions last updated more than `keep_seconds` ago, except the
        newest `keep_last` terminal ones, with their transitions; and the pending controls
        of actions not open. Returns how many actions were dropped."""
        marks = ",".join("?" * len(_TERMINAL))
        cutoff = self.clock() - keep_seconds
        with self._lock:
            self._db.execute("BEGIN IMMEDIATE")
            try:
                row = self._db.execute(
                    f"SELECT updated FROM actions WHERE state IN ({marks}) "
                    f"ORDER BY updated DESC LIMIT 1 OFFSET ?",
                    (*_TERMINAL, max(0, keep_last - 1))).fetchone() if keep_last > 0 else None
                if keep_last > 0:
                    if row is None:  # fewer than keep_last terminal actions: keep them all
                        cutoff = float("-inf")
                    else:
                        cutoff = min(cutoff, float(row[0]))
                self._db.execute("CREATE TEMP TABLE IF NOT EXISTS doomed "
                                 "(uuid TEXT PRIMARY KEY)")
                self._db.execute("DELETE FROM doomed")
                self._db.execute(
                    f"INSERT INTO doomed SELECT uuid FROM actions "
                    f"WHERE state IN ({marks}) AND updated < ?", (*_TERMINAL, cutoff))
                self._db.execute("DELETE FROM transitions WHERE uuid IN "
                                 "(SELECT uuid FROM doomed)")
                cur = self._db.execute("DELETE FROM actions WHERE uuid IN "
                                       "(SELECT uuid FROM doomed)")
                dropped = cur.rowcount
                if dropped > 0:  # the watermark: every terminal action before it is gone
                    self._db.execute(
                        "INSERT INTO compaction VALUES (1, ?, ?) ON CONFLICT(id) DO UPDATE "
                        "SET dropped=dropped+excluded.dropped, "
                        "before=MAX(before, excluded.before)", (dropped, cutoff))
                self._db.execute(
                    f"DELETE FROM controls WHERE uuid NOT IN (SELECT uuid FROM actions "
                    f"WHERE state NOT IN ({marks}))", _TERMINAL)
                self._db.execute("COMMIT")
            except BaseException:
                if self._db.in_transaction:  # SQLite may have rolled back on its own
                    self._db.execute("ROLLBACK")
                raise
            self._db.execute("PRAGMA wal_checkpoint(TRUNCATE)")
        return dropped

    def compaction(self) -> tuple[int, float | None]:
        """How many actions compaction dropped in all, and its watermark (wall-clock
        seconds; None if it never dropped one)."""
        with self._lock:
            row = self._db.execute("SELECT dropped, before FROM compaction").fetchone()
        return (0, None) if row is None else (int(row[0]), float(row[1]))

    def size(self) -> int:
        """Bytes on disk: the database and its write-ahead log."""
        wal = self.path.with_name(self.path.name + "-wal")
        return sum(p.stat().st_size for p in (self.path, wal) if p.exists())


def _entry(row: tuple[Any, ...]) -> JournalEntry:
    (uuid, name, args, robot, goal, priority, literal, state, reason, progress,
     suspended_by, _created, _updated, requester, requester_inc, cause) = row
    action = Action(uuid=uuid, name=name, args=json.loads(args), robot=robot, goal=goal,
                    priority=priority, state=ActionState(state), progress=json.loads(progress),
                    literal=literal, reason=reason, cause=cause)
    return JournalEntry(action, suspended_by, Requester(requester, requester_inc))
