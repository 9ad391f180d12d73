"""Arithmetic: the operators and `math.*` functions of Jason, on Python int/float.

Jason computes with doubles; we keep integers exact where Jason's result is integral
(`/` always yields a real, `div`/`mod` are integer, as in Java).
"""

from __future__ import annotations

import math
from collections.abc import Callable

from mrss.agentspeak.errors import AslRuntimeError
from mrss.agentspeak.jrandom import RNG

Number = int | float


def _div(a: Number, b: Number) -> Number:
    if b == 0:
        raise AslRuntimeError("division by zero")
    q = abs(int(a)) // abs(int(b))
    return q if (a >= 0) == (b >= 0) else -q


def _mod(a: Number, b: Number) -> Number:
    if b == 0:
        raise AslRuntimeError("division by zero")
    return int(a) - int(b) * _div(a, b)  # Java %: the sign of the dividend


def _real_div(a: Number, b: Number) -> Number:
    if b == 0:
        raise AslRuntimeError("division by zero")
    return a / b


MAX_POW_BITS = 1024  # an integer power larger than the largest float is an error


def _pow(a: Number, b: Number) -> Number:
    if type(a) is int and type(b) is int and b >= 0:
        if abs(a) > 1 and b * math.log2(abs(a)) > MAX_POW_BITS:  # before computing it
            raise AslRuntimeError(f"{a} ** {b} is too large (more than about 1.8e308)")
        return a**b  # type: ignore
    try:
        return float(a) ** b
    except (OverflowError, ZeroDivisionError) as exc:
        raise AslRuntimeError(f"{a} ** {b}: {exc}") from exc


def _sqrt(a: Number) -> Number:
    if a < 0:
        raise AslRuntimeError(f"math.sqrt of negative number {a}")
    return math.sqrt(a)


BINARY: dict[str, Callable[[Number, Number], Number]] = {
    "+": lambda a, b: a + b,
    "-": lambda a, b: a - b,
    "*": lambda a, b: a * b,
    "/": _real_div,
    "div": _div,
    "mod": _mod,
    "**": _pow,
}

FUNCTIONS: dict[str, Callable[..., Number]] = {
    "neg": lambda a: -a,
    "math.abs": abs,
    "math.round": lambda a: math.floor(a + 0.5),
    "math.floor": math.floor,
    "math.ceil": math.ceil,
    "math.sqrt": _sqrt,
    "math.max": max,
    "math.min": min,
    "math.random": lambda a=1: RNG.random() * a,
    "math.log": lambda a: math.log(a),
    "math.pi": lambda: math.pi,
    "math.e": lambda: math.e,
}

ARITY: dict[str, tuple[int, ...]] = {
    "neg": (1,), "math.abs": (1,), "math.round": (1,), "math.floor": (1,),
    "math.ceil": (1,), "math.sqrt": (1,), "math.max": (2,), "math.min": (2,),
    "math.random": (0, 1), "math.log": (1,), "math.pi": (0,), "math.e": (0,),
}


def apply_op(op: str, args: list[Number]) -> Number:
    """Apply operator or function `op` to already evaluated numeric arguments."""
    fn2 = BINARY.get(op)
    if fn2 is not None:
        return fn2(args[0], args[1])
    fn = FUNCTIONS.get(op)
    if fn is None:
        raise AslRuntimeError(f"unknown arithmetic function {op}")
    if len(args) not in ARITY[op]:  # a percept's text is parsed at run time: no TypeError
        want = " or ".join(str(n) for n in ARITY[op])
        raise AslRuntimeError(f"{op} takes {want} argument{'s' if want != '1' else ''}, "
                              f"not {len(args)}")
    try:
        return fn(*args)
    except (ValueError, OverflowError) as exc:
        raise AslRuntimeError(f"{op}: {exc}") from exc
