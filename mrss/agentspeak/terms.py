"""AgentSpeak terms: numbers, strings, atoms/structures, variables, lists and triggers.

Runtime terms are plain Python values where possible: `int`/`float` for numbers,
`str` for strings, `tuple` for proper lists. Structures (atoms are structures of
arity 0) are `Struct`; free variables are `Var` (mutable, bound through `ref`).
Templates -- the terms inside compiled plans and rules -- may also hold `Slot`
(a plan variable, bound in a frame list) and `Expr` (arithmetic, evaluated when the
template is resolved against a frame).

A term's text is in `termtext` and their standard order in `termorder`; both are
also importable from here.
"""

from __future__ import annotations

import itertools
from collections.abc import Callable
from typing import Any, TypeAlias

Term: TypeAlias = (
    "int | float | str | Struct | Var | Slot | Expr | PList | Trigger | AnnotTail | VarAnnot"
    " | PlanTerm | tuple[Term, ...]")

# Trigger operators (the kind of an event).
ADD_BEL, DEL_BEL, ADD_ACH, DEL_ACH, ADD_TEST, DEL_TEST, GOAL_STATE = range(7)
OP_TEXT = ("+", "-", "+!", "-!", "+?", "-?", "^!")  # GOAL_STATE: Jason 3's ^!g[state(S)]

_var_ids = itertools.count(1)


class Var:
    """A free runtime variable; `ref` is its binding (None while unbound)."""

    __slots__ = ("ref", "name")

    def __init__(self, name: str = "_") -> None:
        self.ref: Term | None = None
        self.name = name

    def __repr__(self) -> str:
        return f"Var({self.name})"


class Slot:
    """A variable of a compiled plan or rule: index `index` of the frame it runs in."""

    __slots__ = ("index", "name")

    def __init__(self, index: int, name: str) -> None:
        self.index = index
        self.name = name

    def __repr__(self) -> str:
        return f"Slot({self.name}#{self.index})"


class Struct:
    """A literal or compound term: `~functor(args)[annots]`; an atom has no args.

    `ground` is true when no variable, slot or expression occurs inside, so resolving
    and copying can skip it. Equality and hashing are structural (annotations included
    in equality; the belief base keys on `args` alone).
    """

    __slots__ = ("functor", "args", "annots", "neg", "ground")
    ground: bool

    def __init__(
        self,
        functor: str,
        args: tuple[Term, ...] = (),
        annots: tuple[Term, ...] = (),
        neg: bool = False,
    ) -> None:
        self.functor = functor
        self.args = args
        self.annots = annots
        self.neg = neg
        # inline for speed (a Struct is built per goal and belief): `_all_ground` of both
        for a in args:
            t = type(a)
            if t is int or t is str or t is float or (t is Struct and a.ground):  # type: ignore[union-attr]
                continue
            if t is not tuple or not _all_ground(a):  # type: ignore[arg-type]
                self.ground = False
                return
        for a in annots:
            if type(a) is Struct and a.ground:
                continue
            if not _all_ground((a,)):
                self.ground = False
                return
        self.ground = True

    def __eq__(self, other: object) -> bool:
        if type(other) is not Struct:
            return False
        return (
            self.functor == other.functor
            and self.neg == other.neg
            and self.args == other.args
            and self.annots == other.annots
        )

    def __hash__(self) -> int:
        return hash((self.functor, self.args, self.neg))

    def __repr__(self) -> str:
        return f"Struct({term_str(self)})"

    def __str__(self) -> str:
        return term_str(self)

    @property
    def key(self) -> tuple[str, int, bool]:
        """The predicate indicator: functor, arity and strong negation."""
        return (self.functor, len(self.args), self.neg)

    def with_annots(self, annots: tuple[Term, ...]) -> Struct:
        return Struct(self.functor, self.args, annots, self.neg)


class PList:
    """A list with an open tail, `[a, b | T]`; a proper list is a plain tuple."""

    __slots__ = ("items", "tail")

    def __init__(self, items: tuple[Term, ...], tail: Term) -> None:
        self.items = items
        self.tail = tail


class Expr:
    """An arithmetic expression or function call in a template, e.g. `N+1`, `math.abs(X)`."""

    __slots__ = ("op", "args", "fn")

    def __init__(self, op: str, args: tuple[Term, ...]) -> None:
        self.op = op
        self.args = args
        # a function over terms (`.length(L)`, `.count(Q)`): its implementation, given
        # the expression and the frame (attached by the compiler); None for arithmetic
        self.fn: Callable[[Expr, Any], Term] | None = None


class AnnotTail:
    """The open tail of an annotation list, `p[a|T]` or `p[|T]`: always the last element
    of `Struct.annots`; once T is bound to a list its items take its place."""

    __slots__ = ("tail",)

    def __init__(self, tail: Term) -> None:
        self.tail = tail


class VarAnnot:
    """A variable with annotations, `X[source(A)]`: it unifies with a literal whose
    annotations include these, and X takes the literal without its annotations."""

    __slots__ = ("var", "annots")

    def __init__(self, var: Term, annots: tuple[Term, ...]) -> None:
        self.var = var
        self.annots = annots


def splice_annots(annots: tuple[Term, ...]) -> tuple[Term, ...]:
    """Runtime annotations with a bound tail replaced by the items of its list."""
    last = annots[-1]
    if type(last) is not AnnotTail:
        return annots
    tail = deref(last.tail)
    head = annots[:-1]
    if type(tail) is tuple:
        extra: tuple[Term, ...] = tail
        return head + tuple(a for a in extra if a not in head)
    if type(tail) is PList:
        p: PList = tail
        return head + p.items + (AnnotTail(p.tail),)
    return head + (AnnotTail(tail),)


class Trigger:
    """A triggering event used as a term, e.g. the `{+arrived(X)}` argument of `.wait`."""

    __slots__ = ("op", "lit")

    def __init__(self, op: int, lit: Term) -> None:
        self.op = op
        self.lit = lit


class PlanTerm:
    """A plan as a term, `{ @l +!g : c <- b }`. `src` is its `syntax.PlanSrc`; while
    `closed` is false its slots are those of the enclosing statement (a template), once
    closed they are its own (a runtime value, see `planterms.close`)."""

    __slots__ = ("src", "closed")

    def __init__(self, src: Any, closed: bool) -> None:
        self.src = src
        self.closed = closed


def _all_ground(items: tuple[Term, ...]) -> bool:
    for a in items:
        t = type(a)
        if t is Struct:
            if not a.ground:  # type: ignore[union-attr]
                return False
        elif t is int or t is str or t is float:
            continue
        elif t is tuple:
            if not _all_ground(a):  # type: ignore[arg-type]
                return False
        else:
            return False
    return True


def atom(name: str) -> Struct:
    """The atom `name`."""
    return Struct(name)


TRUE = atom("true")
FALSE = atom("false")
SELF = atom("self")
PERCEPT = atom("percept")
SOURCE_SELF = Struct("source", (SELF,))
SOURCE_PERCEPT = Struct("source", (PERCEPT,))
EMPTY: tuple[Term, ...] = ()


def fresh_var(name: str = "_") -> Var:
    """A new free variable; anonymous ones get a unique printable name."""
    return Var(name if name != "_" else f"_{next(_var_ids)}")


def deref(t: Term) -> Term:
    """Follow variable bindings until a non-variable or a free variable."""
    while type(t) is Var:
        r = t.ref
        if r is None:
            return t
        t = r
    return t


def value(t: Term) -> Term:
    """`t` with every bound variable inside replaced by its value (deep dereference)."""
    t = deref(t)
    tt = type(t)
    if tt is Struct:
        s: Struct = t  # type: ignore[assignment]
        if s.ground:
            return s
        annots = tuple([value(a) for a in s.annots])
        return Struct(s.functor, tuple([value(a) for a in s.args]),
                      splice_annots(annots) if annots else annots, s.neg)
    if tt is tuple:
        return tuple([value(a) for a in t])  # type: ignore[union-attr]
    if tt is AnnotTail:
        return AnnotTail(value(t.tail))  # type: ignore[union-attr]
    if tt is VarAnnot:
        return VarAnnot(value(t.var), tuple([value(a) for a in t.annots]))  # type: ignore
    if tt is PList:
        p: PList = t  # type: ignore[assignment]
        items = tuple([value(a) for a in p.items])
        tail = value(p.tail)
        if type(tail) is tuple:
            return items + tail
        if type(tail) is PList:
            return PList(items + tail.items, tail.tail)
        return PList(items, tail)
    if tt is Trigger:
        return Trigger(t.op, value(t.lit))  # type: ignore
    return t


def is_ground(t: Term) -> bool:
    """True when the (dereferenced) term holds no free variable."""
    t = deref(t)
    tt = type(t)
    if tt is Struct:
        s: Struct = t  # type: ignore[assignment]
        return s.ground or (all(is_ground(a) for a in s.args)
                            and all(is_ground(a) for a in s.annots))
    if tt is tuple:
        return all(is_ground(a) for a in t)  # type: ignore[union-attr]
    if tt is PList:
        return False if type(deref(t.tail)) is Var else is_ground(value(t))  # type: ignore[union-attr]
    if tt is Trigger:
        return is_ground(t.lit)  # type: ignore[union-attr]
    if tt is AnnotTail or tt is VarAnnot:
        return False
    return tt is not Var


def rename(t: Term, mapping: dict[int, Var] | None = None) -> Term:
    """A copy of runtime term `t` whose free variables are fresh ones (renaming apart)."""
    t = deref(t)
    tt = type(t)
    if mapping is None:
        mapping = {}
    if tt is Var:
        v = mapping.get(id(t))
        if v is None:
            v = mapping[id(t)] = fresh_var(t.name)  # type: ignore[union-attr]
        return v
    if tt is Struct:
        s: Struct = t  # type: ignore[assignment]
        if s.ground:
            return s
        return Struct(s.functor, tuple([rename(a, mapping) for a in s.args]),
                      tuple([rename(a, mapping) for a in s.annots]), s.neg)
    if tt is tuple:
        return tuple([rename(a, mapping) for a in t])  # type: ignore[union-attr]
    if tt is PList:
        p: PList = t  # type: ignore[assignment]
        return PList(tuple([rename(a, mapping) for a in p.items]), rename(p.tail, mapping))
    if tt is Trigger:
        return Trigger(t.op, rename(t.lit, mapping))  # type: ignore
    if tt is AnnotTail:
        return AnnotTail(rename(t.tail, mapping))  # type: ignore[union-attr]
    if tt is VarAnnot:
        return VarAnnot(rename(t.var, mapping),  # type: ignore[union-attr]
                        tuple([rename(a, mapping) for a in t.annots]))  # type: ignore
    return t


def is_number(t: object) -> bool:
    tt = type(t)
    return tt is int or tt is float


# Moved to modules of their own; still importable from here. Imported last: they build
# on the term types above.
from mrss.agentspeak.termorder import compare as compare  # noqa: E402
from mrss.agentspeak.termtext import format_number as format_number  # noqa: E402
from mrss.agentspeak.termtext import quote as quote  # noqa: E402
from mrss.agentspeak.termtext import term_str as term_str  # noqa: E402
