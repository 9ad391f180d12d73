"""Rules added and removed at run time: `+{ h :- b }` and `-{ h :- b }` in a plan body.

The rule term takes the values of the plan's variables bound at that point (free ones
become the rule's own, as in a plan term). `+{ h :- b }` (and `+>`) adds the rule after
the facts and rules of its predicate; `-{ h :- b }` removes the first rule that reads
the same up to the names of its variables, and does nothing when there is none (as
`-b` for a belief that is not there). No event is posted.
"""

from __future__ import annotations

from typing import TYPE_CHECKING, Any

from mrss.agentspeak.beliefs import Rule
from mrss.agentspeak.errors import AslRuntimeError
from mrss.agentspeak.formulas import compile_query
from mrss.agentspeak.functions import FunctionEnv, bind_functions
from mrss.agentspeak.instructions import Instr
from mrss.agentspeak.planterms import _Closer
from mrss.agentspeak.terms import (
    AnnotTail,
    Expr,
    PList,
    Slot,
    Struct,
    Term,
    VarAnnot,
    term_str,
)

if TYPE_CHECKING:
    from mrss.agentspeak.intentions import IntendedMeans, Intention
    from mrss.agentspeak.runtime import Runtime


def is_rule_term(t: Term) -> bool:
    return type(t) is Struct and t.functor == ":-" and len(t.args) == 2


def _canonical(t: Term, names: dict[int, Slot]) -> Term:
    """`t` with its slots renumbered by first appearance (to compare up to renaming)."""
    tt = type(t)
    if isinstance(t, Slot):
        s = names.get(t.index)
        if s is None:
            s = names[t.index] = Slot(len(names), f"_V{len(names)}")
        return s
    if tt is Struct:
        st: Struct = t  # type: ignore[assignment]
        return Struct(st.functor, tuple(_canonical(a, names) for a in st.args),
                      tuple(_canonical(a, names) for a in st.annots), st.neg)
    if tt is tuple:
        return tuple(_canonical(a, names) for a in t)  # type: ignore[union-attr]
    if tt is PList:
        return PList(tuple(_canonical(a, names) for a in t.items),  # type: ignore[union-attr]
                     _canonical(t.tail, names))  # type: ignore[union-attr]
    if tt is Expr:
        return Expr(t.op, tuple(_canonical(a, names) for a in t.args))  # type: ignore
    if tt is AnnotTail:
        return AnnotTail(_canonical(t.tail, names))  # type: ignore[union-attr]
    if tt is VarAnnot:
        return VarAnnot(_canonical(t.var, names),  # type: ignore[union-attr]
                        tuple(_canonical(a, names) for a in t.annots))  # type: ignore
    return t


def rule_key(head: Term, body: Term) -> str:
    """A text equal for two rules exactly when they are the same up to variable names."""
    names: dict[int, Slot] = {}
    return term_str(Struct(":-", (_canonical(head, names), _canonical(body, names))))


class _RuleChange(Instr):
    __slots__ = ("term",)

    def __init__(self, term: Struct, line: int) -> None:
        super().__init__(line)
        self.term = term

    def closed(self, frame: list[Any]) -> tuple[Struct, Term, int]:
        c = _Closer(frame)
        head = c.term(self.term.args[0])
        body = c.term(self.term.args[1])
        if type(head) is not Struct:
            raise AslRuntimeError(f"the head of rule {term_str(self.term)} is "
                                  f"{term_str(head)}, not a literal")
        return head, body, len(c.names)

    def text(self) -> str:
        return self.prefix + term_str(self.term)


class AddRule(_RuleChange):
    """`+{ h :- b }`: add the rule after the clauses of its predicate."""

    __slots__ = ()
    prefix = "+"

    def run(self, rt: Runtime, it: Intention, im: IntendedMeans) -> None:
        head, body, nslots = self.closed(im.frame)
        env = FunctionEnv()
        env.rt = rt
        problems: list[str] = []
        bind_functions(body, env, lambda q: compile_query(q, rt.registry), problems)
        if problems:
            raise AslRuntimeError(problems[0])
        rule = Rule(head, compile_query(body, rt.registry), nslots, self.line,
                    f"{term_str(head)} :- {term_str(body)}")
        rule.src_body = body
        im.pc += 1
        rt.bb.add_rule((head.functor, len(head.args), head.neg), rule)


class DelRule(_RuleChange):
    """`-{ h :- b }`: remove the first rule that is the same up to variable names."""

    __slots__ = ()
    prefix = "-"

    def run(self, rt: Runtime, it: Intention, im: IntendedMeans) -> None:
        head, body, _ = self.closed(im.frame)
        im.pc += 1
        store = rt.bb.store((head.functor, len(head.args), head.neg))
        if store is None:
            return
        key = rule_key(head, body)
        for rule in store.rules:
            if rule.src_body is not None and rule_key(rule.head, rule.src_body) == key:
                rt.bb.remove_rule(rule.head, rule)
                return
