"""The reasoner's question journal: the agent's questions to the operator, kept across
its restarts (SQLite, WAL), as the RCL keeps its actions.

A question is written here when it is asked, before anyone hears of it, and again when
it is settled (answered, timed out, withdrawn) before the intention that asked goes on;
`consumed` says an intention has had the answer. A new incarnation of the reasoner reads
every question back: a pending one is asked again by the agent, which re-derives its
intentions from its standing percepts, and adopts it (same id, same deadline); one
settled but not consumed (answered while the reasoner was down, or timed out) gives its
answer at once to the intention that asks it again. The first incarnation of a run
starts with an empty journal.
"""

from __future__ import annotations

import json
import threading
from dataclasses import dataclass
from pathlib import Path

from mrss.messages import QuestionState
from mrss.sqlite_checkpoint import connect_wal

_SCHEMA = """
CREATE TABLE IF NOT EXISTS questions (
    seq INTEGER PRIMARY KEY AUTOINCREMENT,
    id TEXT UNIQUE NOT NULL, agent TEXT NOT NULL, question TEXT NOT NULL,
    choices TEXT NOT NULL, dflt TEXT NOT NULL, deadline REAL NOT NULL,
    asked_at REAL NOT NULL, state TEXT NOT NULL, answer TEXT NOT NULL DEFAULT '',
    by TEXT NOT NULL DEFAULT '', answered_at REAL NOT NULL DEFAULT 0,
    request TEXT NOT NULL DEFAULT '', consumed INTEGER NOT NULL DEFAULT 0
);
"""
_COLUMNS = ("id, agent, question, choices, dflt, deadline, asked_at, state, answer, by, "
            "answered_at, request, consumed")


@dataclass
class Question:
    """One question as journaled; `choices` and answers are the choices' texts."""

    id: str
    agent: str
    question: str
    choices: list[str]
    default: str
    deadline: float  # wall-clock time; 0: none
    asked_at: float
    state: QuestionState = QuestionState.PENDING
    answer: str = ""
    by: str = ""
    answered_at: float = 0.0
    request: str = ""  # the answer message's request id (a repeat of it is not refused)
    consumed: bool = False

    @property
    def key(self) -> tuple[str, str, tuple[str, ...]]:
        """What makes two asks the same question (for adoption after a restart)."""
        return (self.agent, self.question, tuple(self.choices))


class QuestionJournal:
    """Every question of one reasoner; thread-safe (one connection, one lock)."""

    def __init__(self, path: str | Path, *, fresh: bool = False) -> None:
        self.path = Path(path)
        self._lock = threading.Lock()
        self._db = connect_wal(self.path)  # survives a killed process
        self._db.executescript(_SCHEMA)
        if fresh:
            self._db.execute("DELETE FROM questions")

    def add(self, q: Question) -> None:
        with self._lock:
            self._db.execute(
                f"INSERT INTO questions ({_COLUMNS}) VALUES (?,?,?,?,?,?,?,?,?,?,?,?,?)",
                (q.id, q.agent, q.question, json.dumps(q.choices), q.default, q.deadline,
                 q.asked_at, q.state.value, q.answer, q.by, q.answered_at, q.request,
                 int(q.consumed)))

    def settle(self, q: Question) -> None:
        """Write `q`'s end (state, answer, who, when, request) and whether it is consumed."""
        with self._lock:
            self._db.execute("UPDATE questions SET state=?, answer=?, by=?, answered_at=?, "
                             "request=?, consumed=? WHERE id=?",
                             (q.state.value, q.answer, q.by, q.answered_at, q.request,
                              int(q.consumed), q.id))

    def all(self) -> list[Question]:
        """Every question, oldest first."""
        with self._lock:
            rows = self._db.execute(f"SELECT {_COLUMNS} FROM questions ORDER BY seq").fetchall()
        return [Question(r[0], r[1], r[2], list(json.loads(r[3])), r[4], float(r[5]),
                         float(r[6]), QuestionState(r[7]), r[8], r[9], float(r[10]), r[11],
                         bool(r[12])) for r in rows]

    def close(self) -> None:
        with self._lock:
            self._db.close()
