"""Belief updates whose literal is a variable: `+S`, `+>S`, `-S`, `-+S` (Jason allows
them: the variable's value at that point is the literal, annotated `source(self)`
unless it names a source). Rare, so each run builds the instruction its literal would
have compiled to and runs that; a free variable or a value that is no literal fails
the intention with the reason."""

from __future__ import annotations

from typing import TYPE_CHECKING

from mrss.agentspeak.errors import AslRuntimeError
from mrss.agentspeak.instructions import (
    AddBelief,
    DelBelief,
    Instr,
    ReplaceBelief,
    goal_literal,
)
from mrss.agentspeak.terms import Term, Var, VarAnnot, term_str
from mrss.agentspeak.unify import resolve

if TYPE_CHECKING:
    from mrss.agentspeak.intentions import IntendedMeans, Intention
    from mrss.agentspeak.runtime import Runtime

PREFIX = {"add": "+", "add_end": "+>", "del": "-", "replace": "-+"}


class BeliefVar(Instr):
    """`+S` (kind `add`), `+>S` (`add_end`), `-S` (`del`) or `-+S` (`replace`)."""

    __slots__ = ("lit", "kind", "prefix")

    def __init__(self, kind: str, lit: Term, line: int) -> None:
        super().__init__(line)
        self.kind = kind
        self.lit = lit
        self.prefix = PREFIX[kind]

    def run(self, rt: Runtime, it: Intention, im: IntendedMeans) -> bool | None:
        value = resolve(self.lit, im.frame)
        if type(value) is Var or type(value) is VarAnnot:
            raise AslRuntimeError(f"unbound variable {term_str(self.lit)} used as a "
                                  f"belief in {self.prefix}{term_str(self.lit)}")
        try:
            lit = goal_literal(value, None)
        except AslRuntimeError:
            raise AslRuntimeError(f"{self.prefix}{term_str(self.lit)}: "
                                  f"{term_str(value)} is not a literal") from None
        kind = self.kind
        if kind == "del":
            return DelBelief(lit, self.line).run(rt, it, im)
        if kind == "replace":
            ReplaceBelief(lit, self.line).run(rt, it, im)
            return None
        return AddBelief(lit, kind == "add", self.line).run(rt, it, im)
