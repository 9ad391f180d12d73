"""Type tests: .atom .number .string .list .literal .structure .ground .type, with
Jason's meaning (an annotated or negated literal is not an atom; a list is a structure
but not a literal; a logical formula is a structure but not a literal)."""

from __future__ import annotations

from collections.abc import Callable, Iterator
from typing import Any

from mrss.agentspeak.registry import IAContext
from mrss.agentspeak.stdlib import STDLIB
from mrss.agentspeak.terms import PList, Struct, Term, Var, deref, is_ground, is_number
from mrss.agentspeak.unify import undo

_FORMULAS = frozenset({"&", "|", "not", "<", ">", "<=", ">=", "==", "\\==", "="})


def is_atom(t: Term) -> bool:
    return type(t) is Struct and not t.args and not t.annots and not t.neg \
        and t.functor not in _FORMULAS


def is_literal(t: Term) -> bool:
    return type(t) is Struct and t.functor not in _FORMULAS


def is_list(t: Term) -> bool:
    return type(t) is tuple or type(t) is PList


def is_structure(t: Term) -> bool:
    return type(t) is Struct or type(t) is tuple or type(t) is PList


# in Jason's order, the most primitive first (what `.type(X, T)` enumerates)
TYPES: tuple[tuple[str, Callable[[Term], bool]], ...] = (
    ("number", is_number),
    ("atom", is_atom),
    ("literal", is_literal),
    ("string", lambda t: type(t) is str),
    ("list", is_list),
    ("structure", is_structure),
    ("ground", lambda t: type(t) is not Var and is_ground(t)),
    ("free", lambda t: type(t) is Var),
)
_TESTS = dict(TYPES)


def _register(name: str) -> None:
    test = _TESTS[name]

    def check(ctx: IAContext, args: list[Any]) -> bool:
        return test(deref(args[0]))

    check.__doc__ = f"`.{name}(X)`: whether X is a {name}."
    STDLIB.register(f".{name}", check, min_args=1, max_args=1)


for _name in ("number", "atom", "literal", "string", "list", "structure", "ground"):
    _register(_name)


@STDLIB.action(".type", min_args=2, max_args=2)
def type_(ctx: IAContext, args: list[Any]) -> Iterator[None]:
    """`.type(X, T)`: T is each type of X in turn (number, atom, literal, string, list,
    structure, ground, free); with T bound, whether X is of that type."""
    t = deref(args[0])
    trail = ctx.runtime.trail
    for name, test in TYPES:
        mark = len(trail)
        if test(t) and ctx.unify(args[1], Struct(name)):
            yield
        undo(trail, mark)
