"""Templates and simple contexts compiled to Python functions (the hot paths of a cycle).

`resolver(t)` is a function `frame -> term` equal to `unify.resolve(t, frame)`;
`tester(q)`, for a conjunction `q` (a context, an `if`/`while` condition), is a
function `(rt, frame) -> bool` equal to "does `q.solve(rt, frame)` have a first
solution" (its bindings kept, as a caller that stops at the first solution keeps
them), or None when the query's own generator would do as well.

Both are generated as Python source and compiled once per plan formula. The generated
code takes a fast path for the common case -- slots holding numbers, strings or
ground structures, arithmetic and comparisons on numbers -- and calls the general
functions (`resolve`, `evaluate`, `Query.solve`) otherwise, so errors and corner
cases behave exactly as without it. Terms the generator does not handle (open
lists, annotation tails, functions like `.count`) use the general function whole.
"""

from __future__ import annotations

from collections.abc import Callable
from types import CodeType
from typing import TYPE_CHECKING, Any

from mrss.agentspeak.arith import BINARY
from mrss.agentspeak.formulas import AndQuery, FalseQuery, NotQuery, Query, RelQuery, TrueQuery
from mrss.agentspeak.terms import Expr, Slot, Struct, Term, _all_ground, fresh_var, value
from mrss.agentspeak.unify import evaluate, resolve

if TYPE_CHECKING:
    from mrss.agentspeak.runtime import Runtime

Resolver = Callable[[list[Any]], Term]
Tester = Callable[["Runtime", list[Any]], bool]

MAX_NODES = 64  # larger templates are resolved by the general function
MAX_LOOPS = 12  # a context with more belief queries keeps its general query
_INLINE_OPS = {"+": "+", "-": "-", "*": "*"}
_COMPARE = {"<": "<", ">": ">", "<=": "<=", ">=": ">=", "==": "==", "\\==": "!="}
_PLAIN = (int, str, float)
_NUM = (int, float)


def _slot(frame: list[Any], idx: int, name: str) -> Term:
    """`resolve` of a slot whose value is not a plain int/str/float."""
    v = frame[idx]
    if v is None:
        v = frame[idx] = fresh_var(name)
        return v
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
            return f"(-{a} if type({a} := {self.operand(e.args[0])}) in _NUM else {slow})"
        if len(e.args) == 2 and e.op in BINARY:
            left, right = e.args
            if e.op in ("mod", "div") and type(right) is int and right > 0:
                # Java's integer `%` and `/` (the sign of the dividend) on an int
                a = self.temp()
                r = str(right)
                done = (f"({a} % {r} if {a} >= 0 else -(-{a} % {r}))" if e.op == "mod" else
                        f"({a} // {r} if {a} >= 0 else -(-{a} // {r}))")
                return f"({done} if type({a} := {self.operand(left)}) is int else {slow})"
            a, b, test = self.numbers(left, right)
            op = _INLINE_OPS.get(e.op)
            done = f"{a} {op} {b}" if op else f"{self.const(BINARY[e.op])}({a}, {b})"
            return f"({done} if {test} else {slow})"
        return slow

    def numbers(self, left: Term, right: Term) -> tuple[str, str, str]:
        """Names for two operands and the test that both are numbers (a number
        constant needs none)."""
        names: list[str] = []
        tests: list[str] = []
        for t in (left, right):
            if type(t) is int or type(t) is float:
                names.append(repr(t) if type(t) is int else self.const(t))
                continue
            v = self.temp()
            names.append(v)
            tests.append(f"type({v} := {self.operand(t)}) in _NUM")
        return names[0], names[1], " and ".join(tests) or "True"

    def operand(self, t: Term) -> str:
        """An expression for an arithmetic operand that the caller tests for a number
        (falling back to the general function): a slot is read from the frame as it is
        (a variable or an unbound slot is no number: the general path deals with it)."""
        if type(t) is Slot:
            self.nodes += 1
            return f"f[{t.index}]"
        return self.term(t)

    def condition(self, q: Query) -> str | None:
        """A Python boolean expression (over `rt`, `f`) for a query with one solution at
        most, or None if `q` may have several (then it needs a loop)."""
        tq = type(q)
        if tq is TrueQuery:
            return "True"
        if tq is FalseQuery:
            return "False"
        if tq is NotQuery:  # one solution at most, binding nothing
            return f"_first({self.const(q)}, rt, f)"
        if tq is RelQuery:
            r: RelQuery = q  # type: ignore[assignment]
            op = _COMPARE.get(r.op)
            slow = f"_first({self.const(q)}, rt, f)"
            if op is None:  # `=`: one solution at most
                return slow
            a1, b1, test = self.numbers(r.left, r.right)
            return f"(({a1} {op} {b1}) if {test} else {slow})"
        return None

    def conjunction(self, parts: list[Query], depth: int = 1, fail: str = "return False",
                    success: tuple[str, ...] = ("return True",)) -> tuple[list[str], int]:
        """Lines (indented from `depth`) running conjunction `parts`: the conditions as
        `if`s, each query with several solutions as a `for` over its solutions (a later
        condition that fails tries the next one: backtracking; each query's solutions
        undo the bindings made after it before the next). On the first solution the
        `success` lines run (they must leave the block: `return`); a failure outside
        every loop runs `fail`; when the loops are exhausted control falls through.
        Returns the lines and the depth of the innermost block."""
        lines: list[str] = []
        first = depth
        for part in parts:
            pad = "    " * depth
            cond = self.condition(part)
            if cond is None:
                if depth - first >= MAX_LOOPS:
                    raise _TooBig  # Python allows 20 nested blocks
                lines.append(f"{pad}for _ in {self.const(part)}.solve(rt, f):")
                depth += 1
            else:
                lines.append(f"{pad}if not {cond}:")
                lines.append(f"{pad}    {fail if depth == first else 'continue'}")
        lines.extend("    " * depth + line for line in success)
        return lines, depth


def _conjuncts(q: Query) -> list[Query]:
    if type(q) is AndQuery:
        a: AndQuery = q
        return _conjuncts(a.left) + _conjuncts(a.right)
    return [q]


class _TooBig(Exception):
    """The template or query is not handled: use the general function."""


def _is_ground_const(t: Term) -> bool:
    return type(t) is Struct and t.ground


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


_CODE: dict[tuple[str, str], CodeType] = {}  # agents of one program share the code
MAX_CODE = 4096


def compiled(source: str, name: str) -> CodeType:
    """`source` compiled, once per process: its constants are names bound when it is
    run (`_Gen.const`), so many agents of the same program compile each function once
    and share its code object (memory, and the interpreter's specialisation of it)."""
    code = _CODE.get((source, name))
    if code is None:
        if len(_CODE) >= MAX_CODE:
            _CODE.clear()
        code = _CODE[(source, name)] = compile(source, name, "exec")
    return code


def _build(name: str, params: str, body: str, env: dict[str, Any]) -> Any:
    code = compiled(f"def {name}({params}):\n    return {body}\n", f"<asl {name}>")
    exec(code, env)  # noqa: S102 -- our own generated code
    return env[name]


def _struct_lines(g: _Gen, st: Struct) -> list[str]:
    """The body of a function building `st` (not ground, its annotations ground
    constants) without `Struct.__init__`: the arguments into locals, the object's
    fields set, and `ground` from the arguments' types (the general test only when an
    argument is not a plain number or string)."""
    names: list[str] = []
    lines: list[str] = []
    plain: list[str] = []
    for a in st.args:
        if type(a) in _PLAIN or _is_ground_const(a):
            names.append(g.const(a))
            continue
        x = g.temp()
        lines.append(f"    {x} = {g.term(a)}")
        names.append(x)
        plain.append(f"type({x}) in _PLAIN")
    args = "(" + "".join(n + ", " for n in names) + ")"
    lines += ["    s = _new(Struct)", f"    s.functor = {g.const(st.functor)}",
              f"    s.args = a = {args}", f"    s.annots = {g.const(st.annots)}",
              f"    s.neg = {st.neg!r}",
              f"    s.ground = True if {' and '.join(plain) or 'True'} else _all_ground(a)",
              "    return s"]
    return lines


def resolver(t: Term) -> Resolver:
    """A function `frame -> term` computing `resolve(t, frame)`."""
    if type(t) is Struct and t.ground:
        return lambda frame: t
    g = _Gen()
    try:
        if type(t) is Struct and all(_is_ground_const(a) for a in t.annots):
            g.env.update(_new=object.__new__, _all_ground=_all_ground)
            src = "def resolve_template(f):\n" + "\n".join(_struct_lines(g, t)) + "\n"
            exec(compiled(src, "<asl resolve_template>"), g.env)  # noqa: S102
            fn: Resolver = g.env["resolve_template"]
        else:
            fn = _build("resolve_template", "f", g.term(t), g.env)
    except (_TooBig, RecursionError, SyntaxError):  # SyntaxError: nested too deeply
        return lambda frame: resolve(t, frame)
    return fn


def tester(q: Query | None) -> Tester | None:
    """A function `(rt, frame) -> bool`: whether `q` has a solution (its first
    solution's bindings kept in the frame), or None if `q` is not simple enough."""
    if q is None:
        return None
    g = _Gen()
    try:
        parts = _conjuncts(q)
        if len(parts) == 1 and type(q) not in (RelQuery, NotQuery):
            return None  # a single general query: its own generator is as fast
        if len(parts) > MAX_NODES:
            raise _TooBig
        lines, depth = g.conjunction(parts)
        if depth > 1:
            lines.append("    return False")
        src = "def test_context(rt, f):\n" + "\n".join(lines) + "\n"
        code = compiled(src, "<asl test_context>")
    except (_TooBig, RecursionError, SyntaxError):  # SyntaxError: loops nested too deep
        return None
    exec(code, g.env)  # noqa: S102 -- our own generated code
    fn: Tester = g.env["test_context"]
    return fn
