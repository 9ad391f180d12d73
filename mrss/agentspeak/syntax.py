"""The parsed form of an AgentSpeak program: statements and plan-body formulas.

Terms inside are already templates: each statement's variables are `Slot`s numbered
from 0 in order of appearance, and `nslots` says how large a frame it needs. Logical
formulas are `Struct`s with the functors `&`, `|`, `not` and the relational operators.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

from mrss.agentspeak.terms import Struct, Term

MAX_INT_DIGITS = 308  # an integer literal must fit a float: arithmetic mixes the two


def number_value(text: str) -> int | float | None:
    """The value of an unsigned number literal, or None when it does not fit a finite
    float (`1e400`, a 400-digit integer): such a literal is a syntax error, not `inf`."""
    if "." in text or "e" in text or "E" in text:
        value = float(text)
        return value if math.isfinite(value) else None
    if len(text.lstrip("0")) > MAX_INT_DIGITS:
        return None
    return int(text)


@dataclass
class BodyItem:
    """One simple body formula. `kind` is one of: achieve, achieve_new, test, add,
    add_end, del, replace, action, ia, constraint."""

    kind: str
    term: Term
    line: int
    col: int = 1


@dataclass
class IfItem:
    """`if (c) {..} elif (c) {..} else {..}`: the (condition, body) branches in order."""

    branches: list[tuple[Term, list[BodyNode]]]
    else_body: list[BodyNode] | None
    line: int


@dataclass
class LoopItem:
    """`while (c) {..}` (kind "while") or `for (c) {..}` (kind "for")."""

    kind: str
    cond: Term
    body: list[BodyNode]
    line: int


BodyNode = BodyItem | IfItem | LoopItem


@dataclass
class PlanSrc:
    """A plan: `@label[annots] op trigger : context <- body.`"""

    label: Struct | None
    op: int
    trigger: Struct
    context: Term | None
    body: list[BodyNode]
    line: int
    nslots: int
    annots: tuple[Term, ...] = ()
    varnames: list[str] = field(default_factory=list)
    file: str | None = None  # the included file it comes from, if not the agent's own
    anon_label: bool = False  # a plan term labelled `@_`: a label left free (label None)


@dataclass
class RuleSrc:
    """A rule `head :- body.`"""

    head: Struct
    body: Term
    line: int
    nslots: int
    file: str | None = None


@dataclass
class BeliefSrc:
    """An initial belief `lit.`"""

    lit: Struct
    line: int
    nslots: int = 0
    file: str | None = None


@dataclass
class GoalSrc:
    """An initial goal `!lit.`"""

    lit: Struct
    line: int
    nslots: int = 0
    file: str | None = None


Statement = PlanSrc | RuleSrc | BeliefSrc | GoalSrc


@dataclass
class Program:
    """All statements of one source, in source order."""

    file: str
    statements: list[Statement] = field(default_factory=list)
