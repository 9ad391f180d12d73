"""Logical formulas compiled to queries: contexts, rule bodies, conditions, `.findall`.

`query.solve(rt, frame)` is a generator yielding once per solution with the bindings
in `frame` (and on runtime variables); resuming it undoes them before the next try.
Callers that want only the first solution stop iterating and keep the bindings.
"""

from __future__ import annotations

import operator
from collections.abc import Iterator
from itertools import combinations
from typing import TYPE_CHECKING, Any

from mrss.agentspeak.beliefs import NO_KEY, first_key
from mrss.agentspeak.errors import AslRuntimeError
from mrss.agentspeak.planterms import plan_text_unlabelled
from mrss.agentspeak.terms import (
    AnnotTail,
    PlanTerm,
    Slot,
    Struct,
    Term,
    Var,
    VarAnnot,
    compare,
    deref,
    is_number,
    rename,
    term_str,
)
from mrss.agentspeak.unify import resolve, strict_var_annot, undo, unify

if TYPE_CHECKING:
    from mrss.agentspeak.registry import InternalAction, Registry
    from mrss.agentspeak.runtime import Runtime

RELATIONAL = {"<", ">", "<=", ">=", "==", "\\==", "="}


class Query:
    """A compiled logical formula."""

    __slots__ = ()

    def solve(self, rt: Runtime, frame: Any) -> Iterator[None]:
        raise NotImplementedError


class TrueQuery(Query):
    __slots__ = ()

    def solve(self, rt: Runtime, frame: Any) -> Iterator[None]:
        yield


class FalseQuery(Query):
    __slots__ = ()

    def solve(self, rt: Runtime, frame: Any) -> Iterator[None]:
        return
        yield


def _ground_args(args: tuple[Term, ...], frame: Any) -> tuple[Term, ...] | None:
    """The argument values when all are ground (for a direct lookup), else None."""
    out: list[Term] = []
    for a in args:
        ta = type(a)
        if ta is Slot:
            a = frame[a.index]  # type: ignore[union-attr]
            if a is None:
                return None
            if type(a) is Var:
                a = deref(a)
                if type(a) is Var:
                    return None
            ta = type(a)
        if ta is Struct:
            if not a.ground:  # type: ignore[union-attr]
                return None
        elif ta is not int and ta is not str and ta is not float:
            return None
        out.append(a)
    return tuple(out)


class LiteralQuery(Query):
    """A literal: matches beliefs of its predicate, newest `+b` first, then rules."""

    __slots__ = ("lit", "key", "direct", "nannots")

    def __init__(self, lit: Struct) -> None:
        self.lit = lit
        self.key = (lit.functor, len(lit.args), lit.neg)
        # Jason's nbAnnots (Literal.logicalConsequence): a query with annotations and no
        # tail backtracks over each set of that many annotations of a fact
        annots = lit.annots
        self.nannots = len(annots) if annots and type(annots[-1]) is not AnnotTail else 0
        # arguments are plain slots or constants and no annotations: a ground instance can
        # be looked up directly instead of scanned for
        self.direct = not lit.annots and all(
            type(a) in (Slot, int, float, str) or (type(a) is Struct and a.ground)
            for a in lit.args)

    def solve(self, rt: Runtime, frame: Any) -> Iterator[None]:
        store = rt.bb.preds.get(self.key)
        if store is None:
            return
        lit = self.lit
        if self.direct and not store.rules:
            args = _ground_args(lit.args, frame)
            if args is not None:
                if store.get(args) is not None:
                    yield
                return
        trail = rt.trail
        mark = len(trail)
        if store.rules:
            yield from self._with_rules(rt, frame, store)
            return
        facts = None
        if lit.args:  # a bound first argument: only the facts indexed under it
            a0: Any = lit.args[0]
            if type(a0) is Slot:
                a0 = frame[a0.index]
                if type(a0) is Var:
                    a0 = deref(a0)
            if a0 is not None:
                key = first_key(a0)
                if key is not NO_KEY:
                    facts = store.facts_with_first(key)
        k = self.nannots
        for b in store.facts() if facts is None else facts:
            if not b.ground:
                b = rename(b)  # type: ignore[assignment]
            if k:
                yield from self._annot_options(b, frame, trail, mark)
                continue
            if unify(lit, frame, b, trail):
                yield
            undo(trail, mark)

    def _annot_options(self, b: Struct, frame: Any, trail: list[Any],
                       mark: int) -> Iterator[None]:
        """Fact `b` with each set of the query's number of its annotations, in order
        (Jason's ListTermImpl.subSets): `.findall(A, c[A], L)` gives every annotation of
        c, `p[source(S)]` every source."""
        lit = self.lit
        if len(b.annots) < self.nannots:
            return
        for subset in combinations(b.annots, self.nannots):
            if unify(lit, frame, Struct(b.functor, b.args, subset, b.neg), trail):
                yield
            undo(trail, mark)

    def _with_rules(self, rt: Runtime, frame: Any, store: Any) -> Iterator[None]:
        """Facts and rules of the predicate in Jason's one order (see `clauses`)."""
        lit = self.lit
        trail = rt.trail
        mark = len(trail)
        q = None
        for c in store.clauses():
            if type(c) is Struct:
                b: Any = c if c.ground else rename(c)
                if self.nannots:
                    yield from self._annot_options(b, frame, trail, mark)
                elif unify(lit, frame, b, trail):
                    yield
            else:
                if q is None:
                    q = resolve(Struct(lit.functor, lit.args, (), lit.neg), frame)
                rframe: list[Any] = [None] * c.nslots
                head = c.head
                if unify(Struct(head.functor, head.args, (), head.neg), rframe, q, trail):
                    for _ in c.body.solve(rt, rframe):
                        yield
            undo(trail, mark)


class AndQuery(Query):
    __slots__ = ("left", "right")

    def __init__(self, left: Query, right: Query) -> None:
        self.left = left
        self.right = right

    def solve(self, rt: Runtime, frame: Any) -> Iterator[None]:
        right = self.right
        for _ in self.left.solve(rt, frame):
            yield from right.solve(rt, frame)


class OrQuery(Query):
    __slots__ = ("left", "right")

    def __init__(self, left: Query, right: Query) -> None:
        self.left = left
        self.right = right

    def solve(self, rt: Runtime, frame: Any) -> Iterator[None]:
        yield from self.left.solve(rt, frame)
        yield from self.right.solve(rt, frame)


class NotQuery(Query):
    """Negation as failure: holds when the inner formula has no solution."""

    __slots__ = ("inner",)

    def __init__(self, inner: Query) -> None:
        self.inner = inner

    def solve(self, rt: Runtime, frame: Any) -> Iterator[None]:
        trail = rt.trail
        mark = len(trail)
        for _ in self.inner.solve(rt, frame):
            undo(trail, mark)
            return
        yield


def _check_bound(v: Term, t: Term) -> None:
    if type(v) is Var:
        raise AslRuntimeError(f"unbound variable {term_str(v)} in comparison {term_str(t)}")


_ORDER = {"<": operator.lt, ">": operator.gt, "<=": operator.le, ">=": operator.ge}


class RelQuery(Query):
    """`=` (unification), `==`, `\\==`, and the order comparisons."""

    __slots__ = ("op", "left", "right", "term", "cmp", "lslot", "rslot")

    def __init__(self, op: str, left: Term, right: Term, term: Term) -> None:
        self.op = op
        self.left = left
        self.right = right
        self.term = term
        self.cmp = _ORDER.get(op)
        self.lslot = left.index if type(left) is Slot else -1
        self.rslot = right.index if type(right) is Slot else -1

    def solve(self, rt: Runtime, frame: Any) -> Iterator[None]:
        cmp = self.cmp
        if cmp is not None:  # fast path: numbers in slots or constants
            a: Any = frame[self.lslot] if self.lslot >= 0 else self.left
            b: Any = frame[self.rslot] if self.rslot >= 0 else self.right
            ta = type(a)
            tb = type(b)
            if (ta is int or ta is float) and (tb is int or tb is float):
                if cmp(a, b):
                    yield
                return
        op = self.op
        if op == "=":
            trail = rt.trail
            mark = len(trail)
            right = resolve(self.right, frame)
            if not strict_var_annot(self.left, frame, right) and unify(
                    self.left, frame, right, trail):
                yield
            undo(trail, mark)
            return
        a = resolve(self.left, frame)
        b = resolve(self.right, frame)
        if op == "==":
            ok = equal(a, b)
        elif op == "\\==":
            ok = not equal(a, b)
        else:
            _check_bound(a, self.term)
            _check_bound(b, self.term)
            if is_number(a) and is_number(b):
                c = -1 if a < b else (1 if a > b else 0)
            else:
                c = compare(a, b)
            ok = (c < 0 if op == "<" else c > 0 if op == ">" else c <= 0 if op == "<="
                  else c >= 0)
        if ok:
            yield


def equal(a: Term, b: Term) -> bool:
    """Jason's `==`: the same term (3 == 3.0; an atom is not the string of its text)."""
    a = deref(a)
    b = deref(b)
    if is_number(a):
        return is_number(b) and a == b
    if type(a) is not type(b):
        return False
    if type(a) is Var:
        return a is b
    if type(a) is tuple:
        return len(a) == len(b) and all(  # type: ignore[arg-type]
            equal(x, y) for x, y in zip(a, b, strict=False))  # type: ignore[arg-type]
    if type(a) is PlanTerm:  # Jason's Plan.equals: event, context and body, not the label
        return plan_text_unlabelled(a.src) == plan_text_unlabelled(b.src)  # type: ignore[union-attr]
    return bool(a == b)


class IAQuery(Query):
    """An internal action used as a condition (e.g. `.intend(g)`, `.member(X, L)`)."""

    __slots__ = ("ia", "args", "queries")

    def __init__(self, ia: InternalAction, args: tuple[Term, ...], registry: Registry) -> None:
        self.ia = ia
        self.args = args
        self.queries = {i: compile_query(args[i], registry) for i in ia.formula_args
                        if i < len(args) and type(args[i]) is Struct}

    def solve(self, rt: Runtime, frame: Any) -> Iterator[None]:
        if self.ia.body_only:
            raise AslRuntimeError(f"{self.ia.name} cannot be used in a plan context")
        args = rt.ia_args(self.ia, self.args, self.queries, frame)
        trail = rt.trail
        mark = len(trail)
        res = self.ia.fn(rt.ia_context(None, None, frame, self.ia.name), args)
        if res is None or res is True:
            yield
        elif res is not False:
            for _ in res:
                yield
                undo(trail, mark)
        undo(trail, mark)


class VarQuery(Query):
    """A variable used as a formula: its value is compiled and solved when reached."""

    __slots__ = ("var", "registry")

    def __init__(self, var: Term, registry: Registry) -> None:
        self.var = var
        self.registry = registry

    def solve(self, rt: Runtime, frame: Any) -> Iterator[None]:
        t = resolve(self.var, frame)
        if type(t) is Var:
            raise AslRuntimeError(f"unbound variable {term_str(t)} used as a formula")
        if type(t) is VarAnnot:  # `X[source(a)]` with X free: every belief that matches
            trail = rt.trail
            mark = len(trail)
            for b in list(rt.bb):
                if unify(self.var, frame, b if b.ground else rename(b), trail):
                    yield
                undo(trail, mark)
            return
        yield from compile_query(t, self.registry).solve(rt, frame)


def compile_query(t: Term, registry: Registry) -> Query:
    """Compile a formula template (or runtime term) into a query."""
    tt = type(t)
    if tt is Struct:
        s: Struct = t  # type: ignore[assignment]
        n = len(s.args)
        if n == 2 and s.functor == "&":
            return AndQuery(compile_query(s.args[0], registry), compile_query(s.args[1], registry))
        if n == 2 and s.functor == "|":
            return OrQuery(compile_query(s.args[0], registry), compile_query(s.args[1], registry))
        if n == 1 and s.functor == "not":
            return NotQuery(compile_query(s.args[0], registry))
        if n == 2 and s.functor in RELATIONAL:
            return RelQuery(s.functor, s.args[0], s.args[1], s)
        if n == 0 and not s.annots and not s.neg and s.functor in ("true", "false"):
            return TrueQuery() if s.functor == "true" else FalseQuery()
        if s.functor.startswith("."):
            ia = registry.get(s.functor)
            if ia is None:
                from mrss.agentspeak.unsupported import unknown_action_message

                raise AslRuntimeError(unknown_action_message(s.functor))
            return IAQuery(ia, s.args, registry)
        return LiteralQuery(s)
    if tt is Slot or tt is Var or tt is VarAnnot:
        return VarQuery(t, registry)
    raise AslRuntimeError(f"not a logical formula: {term_str(t)}")
