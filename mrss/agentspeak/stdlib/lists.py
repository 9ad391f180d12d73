"""List internal actions: .member .length .nth .sort .reverse .delete .max .min .range."""

from __future__ import annotations

import functools
from collections.abc import Iterator
from typing import Any

from mrss.agentspeak.registry import IAContext
from mrss.agentspeak.stdlib import STDLIB
from mrss.agentspeak.terms import PList, Term, Var, compare, deref, is_number, term_str, value
from mrss.agentspeak.unify import undo, unify


def list_arg(ctx: IAContext, t: Term) -> tuple[Term, ...]:
    t = value(t)
    if type(t) is tuple:
        return t
    if type(t) is PList:
        raise ctx.error(f"the list {term_str(t)} has an unbound tail")
    raise ctx.error(f"expected a list, not {term_str(t)}")


@STDLIB.action(".member", min_args=2, max_args=2)
def member(ctx: IAContext, args: list[Any]) -> Iterator[None]:
    """`.member(X, L)`: X unifies with each element of L in turn."""
    for item in list_arg(ctx, args[1]):
        if ctx.unify(args[0], item):
            yield


@STDLIB.action(".length", min_args=2, max_args=2)
def length(ctx: IAContext, args: list[Any]) -> bool:
    """Length of a list or a string."""
    t = deref(args[0])
    n = len(t) if type(t) is str else len(list_arg(ctx, t))
    return ctx.unify(args[1], n)


@STDLIB.action(".nth", min_args=3, max_args=3)
def nth(ctx: IAContext, args: list[Any]) -> Iterator[None]:
    """`.nth(N, L, X)`: X is element N (from 0) of L; with N free, every position."""
    items = list_arg(ctx, args[1])
    n = deref(args[0])
    if type(n) is Var:
        trail = ctx.runtime.trail
        for i, item in enumerate(items):
            mark = len(trail)
            if ctx.unify(args[0], i) and ctx.unify(args[2], item):
                yield
            undo(trail, mark)
        return
    if not is_number(n) or int(n) != n:  # type: ignore[arg-type]
        raise ctx.error(f"the index {term_str(n)} is not an integer")
    i = int(n)  # type: ignore[arg-type]
    if not 0 <= i < len(items):
        raise ctx.error(f"index {i} out of range for a list of {len(items)}")
    if ctx.unify(args[2], items[i]):
        yield


_key = functools.cmp_to_key(compare)


@STDLIB.action(".sort", min_args=2, max_args=2)
def sort(ctx: IAContext, args: list[Any]) -> bool:
    """Sort a list in Jason's standard order of terms."""
    return ctx.unify(args[1], tuple(sorted(list_arg(ctx, args[0]), key=_key)))


@STDLIB.action(".reverse", min_args=2, max_args=2)
def reverse(ctx: IAContext, args: list[Any]) -> bool:
    """Reverse a list or a string."""
    t = deref(args[0])
    if type(t) is str:
        return ctx.unify(args[1], t[::-1])
    return ctx.unify(args[1], tuple(reversed(list_arg(ctx, t))))


@STDLIB.action(".delete", min_args=3, max_args=3)
def delete(ctx: IAContext, args: list[Any]) -> bool:
    """`.delete(X, L, R)`: R is L without X; a number X is an index; strings work too."""
    what = deref(args[0])
    source = deref(args[1])
    if type(source) is str:
        return ctx.unify(args[2], source.replace(str(what) if type(what) is str
                                                 else term_str(what, top=True), ""))
    items = list_arg(ctx, source)
    if type(what) is int:
        if not 0 <= what < len(items):
            raise ctx.error(f"index {what} out of range for a list of {len(items)}")
        return ctx.unify(args[2], items[:what] + items[what + 1:])
    trail = ctx.runtime.trail
    kept = []
    for item in items:
        mark = len(trail)
        if not unify(what, None, item, trail):
            kept.append(item)
        undo(trail, mark)
    return ctx.unify(args[2], tuple(kept))


def _extreme(ctx: IAContext, args: list[Any], sign: int) -> bool:
    items = list_arg(ctx, args[0])
    if not items:
        return False
    best = items[0]
    for x in items[1:]:
        if compare(x, best) * sign > 0:
            best = x
    return ctx.unify(args[1], best)


@STDLIB.action(".max", min_args=2, max_args=2)
def max_(ctx: IAContext, args: list[Any]) -> bool:
    """The greatest element of a list (Jason's order); fails on an empty list."""
    return _extreme(ctx, args, 1)


@STDLIB.action(".min", min_args=2, max_args=2)
def min_(ctx: IAContext, args: list[Any]) -> bool:
    """The smallest element of a list (Jason's order); fails on an empty list."""
    return _extreme(ctx, args, -1)


@STDLIB.action(".range", min_args=3, max_args=4)
def range_(ctx: IAContext, args: list[Any]) -> Iterator[None]:
    """`.range(X, Start, End[, Step])`: X takes Start, Start+Step, ... up to End."""
    bounds = [deref(a) for a in args[1:]]
    for b in bounds:
        if not is_number(b):
            raise ctx.error(f"expected a number, not {term_str(b)}")
    start, end = bounds[0], bounds[1]
    step = bounds[2] if len(bounds) > 2 else 1
    if step == 0:
        raise ctx.error("the step must not be 0")
    x = start
    while (x <= end) if step > 0 else (x >= end):  # type: ignore[operator]
        if ctx.unify(args[0], x):
            yield
        x += step  # type: ignore[operator]
