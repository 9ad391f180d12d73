"""Jason's functions over terms, used inside expressions: `.length(L)`, `.count(Q)`,
`math.sum(L)`, `math.average(L)`, `math.median(L)`, `math.std_dev(L)`, and
`math.max(L)`/`math.min(L)` of a list.

The numeric functions (`math.abs`, ...) live in `arith`; these take any term. The
builder makes an `Expr` of a call with a known name and arity; the compiler attaches
its implementation (`bind_functions`), which for `.count` needs the agent's runtime,
reached through the program's `FunctionEnv`.
"""

from __future__ import annotations

from collections.abc import Callable
from typing import TYPE_CHECKING, Any

from mrss.agentspeak.arith import ARITY
from mrss.agentspeak.errors import AslRuntimeError
from mrss.agentspeak.terms import Expr, PList, Struct, Term, Trigger, is_number, term_str

if TYPE_CHECKING:
    from mrss.agentspeak.formulas import Query
    from mrss.agentspeak.runtime import Runtime

# name -> the argument counts at which a call is a function (other counts are internal
# actions, e.g. `.length(L, N)`)
TERM_ARITY: dict[str, tuple[int, ...]] = {
    ".length": (1,), ".count": (1,), "math.sum": (1,), "math.average": (1,),
    "math.median": (1,), "math.std_dev": (1,), "math.max": (1, 2), "math.min": (1, 2),
}


def is_function(name: str, nargs: int) -> bool:
    """Whether `name(args)` with `nargs` arguments is a function call in an expression."""
    arities = TERM_ARITY.get(name)
    if arities is not None:
        return nargs in arities
    return name in ARITY


class FunctionEnv:
    """What the functions of one compiled program need at run time: the agent."""

    __slots__ = ("rt",)

    def __init__(self) -> None:
        self.rt: Runtime | None = None


def _numbers(name: str, t: Term) -> list[float | int]:
    if type(t) is PList:
        raise AslRuntimeError(f"{name}: the list {term_str(t)} has an unbound tail")
    if type(t) is not tuple:
        raise AslRuntimeError(f"{name}: expected a list, not {term_str(t)}")
    return [x for x in t if is_number(x)]  # type: ignore[misc]


def _length(t: Term) -> Term:
    if type(t) is str or type(t) is tuple:
        return len(t)
    raise AslRuntimeError(f".length: {term_str(t)} is not a list or a string")


def _sum(t: Term) -> Term:
    return sum(_numbers("math.sum", t))


def _average(t: Term) -> Term:
    xs = _numbers("math.average", t)
    if not xs:
        raise AslRuntimeError("math.average of an empty list")
    return sum(xs) / len(xs)


def _median(t: Term) -> Term:
    """The middle number, or the mean of the two middle ones (Jason's median.java)."""
    if type(t) is tuple and not all(is_number(x) for x in t):
        raise AslRuntimeError(f"math.median needs a list of numbers, not {term_str(t)}")
    xs = sorted(_numbers("math.median", t))
    if not xs:
        raise AslRuntimeError("math.median of an empty list")
    half = len(xs) // 2
    return xs[half] if len(xs) % 2 else (xs[half - 1] + xs[half]) / 2


def _std_dev(t: Term) -> Term:
    """The sample standard deviation (n - 1), as Jason's StdDev.java."""
    xs = _numbers("math.std_dev", t)
    if len(xs) < 2:
        raise AslRuntimeError("math.std_dev needs two numbers or more")
    mean = sum(xs) / len(xs)
    return float((sum((x - mean) ** 2 for x in xs) / (len(xs) - 1)) ** 0.5)


def _extreme(name: str, pick: Callable[..., Any]) -> Callable[..., Term]:
    def fn(*args: Term) -> Term:
        if len(args) == 2:
            if not (is_number(args[0]) and is_number(args[1])):
                raise AslRuntimeError(f"arithmetic on a non-number in {name}"
                                      f"({term_str(args[0])},{term_str(args[1])})")
            return pick(args[0], args[1])  # type: ignore[no-any-return]
        xs = _numbers(name, args[0])
        if not xs:
            raise AslRuntimeError(f"{name} of a list without numbers")
        return pick(xs)  # type: ignore[no-any-return]
    return fn


_PURE: dict[str, Callable[..., Term]] = {
    ".length": _length, "math.sum": _sum, "math.average": _average,
    "math.median": _median, "math.std_dev": _std_dev,
    "math.max": _extreme("math.max", max), "math.min": _extreme("math.min", min),
}


def _pure_call(fn: Callable[..., Term]) -> Callable[[Expr, Any], Term]:
    def call(e: Expr, frame: Any) -> Term:
        from mrss.agentspeak.unify import resolve

        return fn(*[resolve(a, frame) for a in e.args])
    return call


def _count_call(env: FunctionEnv, query: Query) -> Callable[[Expr, Any], Term]:
    def call(e: Expr, frame: Any) -> Term:
        rt = env.rt
        if rt is None:
            raise AslRuntimeError(".count needs a running agent (not in an initial belief)")
        return sum(1 for _ in query.solve(rt, frame))
    return call


def bind_functions(t: Term, env: FunctionEnv, compile_query: Callable[[Term], Query],
                   problems: list[str]) -> None:
    """Attach implementations to the term-function calls inside template `t`; wrong
    argument counts of a math function are added to `problems`."""
    tt = type(t)
    if tt is Expr:
        e: Expr = t  # type: ignore[assignment]
        for a in e.args:
            bind_functions(a, env, compile_query, problems)
        if e.op == ".count":
            e.fn = _count_call(env, compile_query(e.args[0]))
        elif e.op in _PURE:
            e.fn = _pure_call(_PURE[e.op])
        elif e.op in ARITY and len(e.args) not in ARITY[e.op]:
            want = " or ".join(str(n) for n in ARITY[e.op])
            problems.append(f"{e.op} takes {want} argument{'s' if want != '1' else ''}, "
                            f"not {len(e.args)}")
    elif tt is Struct:
        s: Struct = t  # type: ignore[assignment]
        if not s.ground:
            for a in s.args + s.annots:
                bind_functions(a, env, compile_query, problems)
    elif tt is tuple:
        for a in t:  # type: ignore[union-attr]
            bind_functions(a, env, compile_query, problems)
    elif tt is PList:
        p: PList = t  # type: ignore[assignment]
        for a in p.items + (p.tail,):
            bind_functions(a, env, compile_query, problems)
    elif tt is Trigger:
        bind_functions(t.lit, env, compile_query, problems)  # type: ignore[union-attr]
