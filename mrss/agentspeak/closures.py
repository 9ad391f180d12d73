"""Templates and simple contexts compiled to Python functions (the hot paths of a cycle).

`resolver(t)` is a function `frame -> term` equal to `unify.resolve(t, frame)`;
`tester(q)` is a function `(rt, frame) -> bool` equal to "does `q.solve(rt, frame)`
have a first solution" (its bindings kept, as a caller that stops at the first
solution keeps them), or None when `q` is not simple enough.

Both are generated as Python source and compiled once per plan formula. The generated
code takes a fast path for the common case -- slots holding numbers, strings or
ground structures, arithmetic and comparisons on numbers -- and calls the general
functions (`resolve`, `evaluate`, `Query.solve`) otherwise, so errors and corner
cases behave exactly as without it. Terms the generator does not handle (open
lists, annotation tails, functions like `.count`) use the general function whole.
"""

from __future__ import annotations

from collections.abc import Callable
from typing import TYPE_CHECKING, Any

from mrss.agentspeak.arith import BINARY
from mrss.agentspeak.formulas import AndQuery, FalseQuery, NotQuery, Query, RelQuery, TrueQuery
from mrss.agentspeak.terms import Expr, Slot, Struct, Term, fresh_var, value
from mrss.agentspeak.unify import evaluate, resolve

if TYPE_CHECKING:
    from mrss.agentspeak.runtime import Runtime

Resolver = Callable[[list[Any]], Term]
Tester = Callable[["Runtime", list[Any]], bool]

MAX_NODES = 64  # larger templates are resolved by the general function
_INLINE_OPS = {"+": "+", "-": "-", "*": "*"}
_COMPARE = {"<": "<", ">": ">", "<=": "<=", ">=": ">=", "==": "==", "\\==": "!="}
_PLAIN = (int, str, float)
_NUM = (int, float)


def _slot(frame: list[Any], idx: int, name: str) -> Term:
    """`resolve` of a slot whose value is not a plain int/str/float."""
    v = frame[idx]
    if v is None:
        v = frame[idx] = fresh_var(name)
        return v  # type: ignore[no-any-return]
    return value(v)


def _first(q: Query, rt: Runtime, frame: list[Any]) -> bool:
    for _ in q.solve(rt, frame):
        return True
    return False


class _Gen:
    """Collects the constants and temporaries of one generated function."""

    def __init__(self) -> None:
        self.env: dict[str, Any] = {"Struct": Struct, "_slot": _slot, "_resolve": resolve,
                                    "_eval": evaluate, "_first": _first, "_NUM": _NUM,
                                    "_PLAIN": _PLAIN}
        self.n = 0
        self.nodes = 0

    def const(self, obj: Any) -> str:
        name = f"c{len(self.env)}"
        self.env[name] = obj
        return name

    def temp(self) -> str:
        self.n += 1
        return f"t{self.n}"

    def term(self, t: Term) -> str:
        """A Python expression (over `f`, the frame) resolving template `t`."""
        self.nodes += 1
        if self.nodes > MAX_NODES:
            raise _TooBig
        tt = type(t)
        if tt is Slot:
            s: Slot = t  # type: ignore[assignment]
            v = self.temp()
            return (f"({v} if type({v} := f[{s.index}]) in _PLAIN "
                    f"else _slot(f, {s.index}, {self.const(s.name)}))")
        if tt is int or tt is str or tt is float:
            return self.const(t)
        if tt is Struct:
            st: Struct = t  # type: ignore[assignment]
            if st.ground:
                return self.const(st)
            if any(not _is_ground_const(a) for a in st.annots):
                return f"_resolve({self.const(st)}, f)"
            args = "".join(self.term(a) + ", " for a in st.args)
            return (f"Struct({self.const(st.functor)}, ({args}), {self.const(st.annots)}, "
                    f"{st.neg!r})")
        if tt is tuple:
            items: tuple[Term, ...] = t  # type: ignore[assignment]
            return "(" + "".join(self.term(a) + ", " for a in items) + ")"
        if tt is Expr:
            return self.expr(t)  # type: ignore[arg-type]
        return f"_resolve({self.const(t)}, f)"

    def expr(self, e: Expr) -> str:
        if e.fn is not None or not _pure(e):
            return f"_eval({self.const(e)}, f)"
        slow = f"_eval({self.const(e)}, f)"
        if len(e.args) == 1 and e.op == "neg":
            a = self.temp()
            return f"(-{a} if type({a} := {self.term(e.args[0])}) in _NUM else {slow})"
        if len(e.args) == 2 and e.op in BINARY:
            a, b = self.temp(), self.temp()
            test = (f"type({a} := {self.term(e.args[0])}) in _NUM and "
                    f"type({b} := {self.term(e.args[1])}) in _NUM")
            op = _INLINE_OPS.get(e.op)
            done = f"{a} {op} {b}" if op else f"{self.const(BINARY[e.op])}({a}, {b})"
            return f"({done} if {test} else {slow})"
        return slow

    def test(self, q: Query, last: bool) -> str:
        """A Python boolean expression (over `rt`, `f`) for query `q`; `last` when
        nothing follows it in the conjunction (then it may have several solutions)."""
        tq = type(q)
        if tq is TrueQuery:
            return "True"
        if tq is FalseQuery:
            return "False"
        if tq is AndQuery:
            a: AndQuery = q  # type: ignore[assignment]
            return f"({self.test(a.left, False)} and {self.test(a.right, last)})"
        if tq is RelQuery:
            r: RelQuery = q  # type: ignore[assignment]
            op = _COMPARE.get(r.op)
            slow = f"_first({self.const(q)}, rt, f)"
            if op is None:  # `=`: one solution at most
                return slow
            a1, b1 = self.temp(), self.temp()
            return (f"(({a1} {op} {b1}) if type({a1} := {self.term(r.left)}) in _NUM and "
                    f"type({b1} := {self.term(r.right)}) in _NUM else {slow})")
        if last or tq is NotQuery:  # a negation has one solution at most, binding nothing
            return f"_first({self.const(q)}, rt, f)"
        raise _TooBig  # a query with several solutions followed by more: backtracking


class _TooBig(Exception):
    """The template or query is not handled: use the general function."""


def _is_ground_const(t: Term) -> bool:
    return type(t) is Struct and t.ground  # type: ignore[union-attr]


def _pure(e: Expr) -> bool:
    """Arithmetic over slots and constants only (no function calls inside)."""
    for a in e.args:
        ta = type(a)
        if ta is Expr:
            if a.fn is not None or not _pure(a):  # type: ignore[union-attr, arg-type]
                return False
        elif ta is not Slot and ta is not int and ta is not float:
            return False
    return True


def _build(name: str, params: str, body: str, env: dict[str, Any]) -> Any:
    src = f"def {name}({params}):\n    return {body}\n"
    exec(compile(src, f"<asl {name}>", "exec"), env)  # noqa: S102 -- our own generated code
    return env[name]


def resolver(t: Term) -> Resolver:
    """A function `frame -> term` computing `resolve(t, frame)`."""
    if type(t) is Struct and t.ground:  # type: ignore[union-attr]
        return lambda frame: t
    g = _Gen()
    try:
        body = g.term(t)
    except (_TooBig, RecursionError):
        return lambda frame: resolve(t, frame)
    fn: Resolver = _build("resolve_template", "f", body, g.env)
    return fn


def tester(q: Query | None) -> Tester | None:
    """A function `(rt, frame) -> bool`: whether `q` has a solution (its first
    solution's bindings kept in the frame), or None if `q` is not simple enough."""
    if q is None:
        return None
    g = _Gen()
    try:
        body = g.test(q, True)
    except (_TooBig, RecursionError):
        return None
    if body.startswith("_first(") and body.count("(") == 1:
        return None  # a single general query: its generator is as fast
    fn: Tester = _build("test_context", "rt, f", body, g.env)
    return fn

