"""AgentSpeak terms: numbers, strings, atoms/structures, variables, lists and triggers.

Runtime terms are plain Python values where possible: `int`/`float` for numbers,
`str` for strings, `tuple` for proper lists. Structures (atoms are structures of
arity 0) are `Struct`; free variables are `Var` (mutable, bound through `ref`).
Templates -- the terms inside compiled plans and rules -- may also hold `Slot`
(a plan variable, bound in a frame list) and `Expr` (arithmetic, evaluated when the
template is resolved against a frame).
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
            if type(a) is Struct and a.ground:  # type: ignore[union-attr]
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
    tail = deref(last.tail)  # type: ignore[union-attr]
    head = annots[:-1]
    if type(tail) is tuple:
        extra: tuple[Term, ...] = tail  # type: ignore[assignment]
        return head + tuple(a for a in extra if a not in head)
    if type(tail) is PList:
        p: PList = tail  # type: ignore[assignment]
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
        r = t.ref  # type: ignore[union-attr]
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
            return items + tail  # type: ignore[operator]
        if type(tail) is PList:
            return PList(items + tail.items, tail.tail)  # type: ignore[union-attr]
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


# ----------------------------------------------------------------------------- printing

_OPERATORS = {"&", "|", ">", "<", ">=", "<=", "==", "\\==", "="}


def format_number(n: float | int) -> str:
    """Jason prints integral reals without `.0` (8/2 prints 4)."""
    if type(n) is float:
        if n.is_integer() and abs(n) < 1e15:
            return str(int(n))
        return repr(n)
    return str(n)


def quote(s: str) -> str:
    return '"' + s.replace("\\", "\\\\").replace('"', '\\"').replace("\n", "\\n") + '"'


def term_str(t: Term, top: bool = False) -> str:
    """Jason's text of a term; with `top`, a string prints without quotes (as `.print`)."""
    t = deref(t)
    tt = type(t)
    if tt is str:
        return t if top else quote(t)  # type: ignore
    if tt is int or tt is float:
        return format_number(t)  # type: ignore[arg-type]
    if tt is Struct:
        s: Struct = t  # type: ignore[assignment]
        if s.functor == ":-" and len(s.args) == 2:  # a rule as a term (`.relevant_rules`)
            return f"{{ {term_str(s.args[0])} :- {term_str(s.args[1])} }}"
        if s.functor in _OPERATORS and len(s.args) == 2:
            text = f"({term_str(s.args[0])} {s.functor} {term_str(s.args[1])})"
        elif s.functor == "not" and len(s.args) == 1:
            text = f"not ({term_str(s.args[0])})"
        else:
            text = ("~" + s.functor if "::" not in s.functor else  # ns::~b
                    s.functor.replace("::", "::~", 1)) if s.neg else s.functor
            if s.args:
                text += "(" + ",".join([term_str(a) for a in s.args]) + ")"
        if s.annots:
            text += _annots_str(s.annots)
        return text
    if tt is tuple:
        return "[" + ",".join([term_str(a) for a in t]) + "]"  # type: ignore[union-attr]
    if tt is Var:
        return t.name  # type: ignore[union-attr]
    if tt is PList:
        p: PList = t  # type: ignore[assignment]
        return "[" + ",".join([term_str(a) for a in p.items]) + "|" + term_str(p.tail) + "]"
    if tt is Slot:
        return t.name  # type: ignore[union-attr]
    if tt is Expr:
        e: Expr = t  # type: ignore[assignment]
        if len(e.args) == 2 and not e.op[0].isalpha():
            return f"({term_str(e.args[0])}{e.op}{term_str(e.args[1])})"
        if e.op == "neg":
            return f"(-{term_str(e.args[0])})"
        return e.op + "(" + ",".join([term_str(a) for a in e.args]) + ")"
    if tt is Trigger:
        return OP_TEXT[t.op] + term_str(t.lit)  # type: ignore
    if tt is VarAnnot:
        return term_str(t.var) + _annots_str(t.annots)  # type: ignore[union-attr]
    if tt is AnnotTail:
        return "|" + term_str(t.tail)  # type: ignore[union-attr]
    if tt is PlanTerm:
        from mrss.agentspeak.planterms import plan_term_text
        return plan_term_text(t.src)  # type: ignore[union-attr]
    return repr(t)


def _annots_str(annots: tuple[Term, ...]) -> str:
    last = annots[-1]
    if type(last) is AnnotTail:
        return "[" + ",".join([term_str(a) for a in annots[:-1]]) + term_str(last) + "]"
    return "[" + ",".join([term_str(a) for a in annots]) + "]"


# ----------------------------------------------------------------------------- ordering

def _rank(t: Term) -> int:
    tt = type(t)
    if tt is int or tt is float:
        return 0
    if tt is str:
        return 1
    if tt is tuple or tt is PList:
        return 2
    if tt is Struct:
        return 3
    return 4


def compare(a: Term, b: Term) -> int:
    """Jason's order: numbers < strings < lists < literals (negation, arity, functor,
    arguments, annotations) < variables. Returns -1, 0 or 1."""
    a = deref(a)
    b = deref(b)
    ra, rb = _rank(a), _rank(b)
    if ra != rb:
        return -1 if ra < rb else 1
    if ra == 0 or ra == 1:
        return -1 if a < b else (1 if a > b else 0)  # type: ignore[operator]
    if ra == 2:
        la = _as_items(a)
        lb = _as_items(b)
        if len(la) != len(lb):
            return -1 if len(la) < len(lb) else 1
        return _compare_seq(la, lb)
    if ra == 3:
        sa: Struct = a  # type: ignore[assignment]
        sb: Struct = b  # type: ignore[assignment]
        for x, y in ((sa.neg, sb.neg), (len(sa.args), len(sb.args)), (sa.functor, sb.functor)):
            if x != y:
                return -1 if x < y else 1  # type: ignore[operator]
        c = _compare_seq(sa.args, sb.args)
        if c:
            return c
        if len(sa.annots) != len(sb.annots):
            return -1 if len(sa.annots) < len(sb.annots) else 1
        return _compare_seq(sa.annots, sb.annots)
    na, nb = getattr(a, "name", ""), getattr(b, "name", "")
    return -1 if na < nb else (1 if na > nb else 0)


def _as_items(t: Term) -> tuple[Term, ...]:
    if type(t) is tuple:
        return t  # type: ignore[return-value]
    return t.items + (t.tail,)  # type: ignore


def _compare_seq(a: tuple[Term, ...], b: tuple[Term, ...]) -> int:
    for x, y in zip(a, b, strict=False):
        c = compare(x, y)
        if c:
            return c
    return 0 if len(a) == len(b) else (-1 if len(a) < len(b) else 1)
