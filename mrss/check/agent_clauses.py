"""The agent's program as clauses of placed terms, for the rules that read what it states.

A clause is one statement: a plan (its trigger, context and every body formula, those
in `if`/`while`/`for` included), a rule (head and body), an initial belief or goal. A
variable means the same thing only within its clause. `literals(term)` gives the user
literals inside a formula: through `&`, `|`, `not`, relational operators and internal
actions' arguments (`.wait(free(R))`), and nested compound arguments.
"""

from __future__ import annotations

import re
from collections.abc import Iterator
from dataclasses import dataclass
from pathlib import Path

from mrss.agentspeak.syntax import (
    BeliefSrc,
    BodyItem,
    BodyNode,
    GoalSrc,
    IfItem,
    LoopItem,
    PlanSrc,
    RuleSrc,
)
from mrss.agentspeak.terms import Struct, Term
from mrss.check.agent import AgentUses

LOGIC = frozenset({"&", "|", "not"})
RELATIONAL = frozenset({"<", ">", "<=", ">=", "==", "\\==", "=", "=.."})


@dataclass(frozen=True)
class Placed:
    """A formula of a clause and where it starts (`kind`: a BodyItem kind, or "trigger",
    "context", "head", "body", "belief", "goal")."""

    term: Term
    line: int
    col: int
    kind: str


@dataclass(frozen=True)
class Clause:
    file: Path
    line: int
    terms: tuple[Placed, ...]


def clauses(uses: AgentUses) -> Iterator[Clause]:
    """Every clause of every program the agent check read."""
    for program in uses.programs:
        for s in program.statements:
            file = Path(getattr(s, "file", None) or program.file)
            if isinstance(s, PlanSrc):
                placed = [Placed(s.trigger, s.line, 1, "trigger")]
                if s.context is not None:
                    placed.append(Placed(s.context, s.line, 1, "context"))
                placed += _body(s.body)
                yield Clause(file, s.line, tuple(placed))
            elif isinstance(s, RuleSrc):
                yield Clause(file, s.line, (Placed(s.head, s.line, 1, "head"),
                                            Placed(s.body, s.line, 1, "body")))
            elif isinstance(s, BeliefSrc):
                yield Clause(file, s.line, (Placed(s.lit, s.line, 1, "belief"),))
            elif isinstance(s, GoalSrc):
                yield Clause(file, s.line, (Placed(s.lit, s.line, 1, "goal"),))


def _body(body: list[BodyNode]) -> list[Placed]:
    placed: list[Placed] = []
    for node in body:
        if isinstance(node, BodyItem):
            placed.append(Placed(node.term, node.line, node.col, node.kind))
        elif isinstance(node, IfItem):
            for cond, branch in node.branches:
                placed.append(Placed(cond, node.line, 1, "condition"))
                placed += _body(branch)
            placed += _body(node.else_body or [])
        elif isinstance(node, LoopItem):
            placed.append(Placed(node.cond, node.line, 1, "condition"))
            placed += _body(node.body)
    return placed


def literals(term: Term) -> Iterator[Struct]:
    """The user literals in a formula (not the connectives or internal actions themselves)."""
    if type(term) is not Struct:
        return
    if term.functor in LOGIC or term.functor in RELATIONAL or term.functor.startswith("."):
        for arg in term.args:
            yield from literals(arg)
        return
    yield term
    for arg in term.args:
        if type(arg) is Struct and arg.args:
            yield from literals(arg)


class SourceLines:
    """The text of the agent's files, to put a column on an atom a statement names."""

    def __init__(self) -> None:
        self._lines: dict[Path, list[str]] = {}

    def column(self, file: Path, line: int, word: str, start: int = 1) -> int:
        if file not in self._lines:
            try:
                self._lines[file] = file.read_text(encoding="utf-8").splitlines()
            except (OSError, UnicodeDecodeError):
                self._lines[file] = []
        lines = self._lines[file]
        if not 0 < line <= len(lines):
            return 0
        found = re.compile(rf"(?<![\w.]){re.escape(word)}(?!\w)").search(
            lines[line - 1], max(start - 1, 0))
        return found.start() + 1 if found else 0
