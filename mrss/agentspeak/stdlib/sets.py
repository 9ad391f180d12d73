"""Lists as sequences and sets: .empty .shuffle .prefix .suffix .sublist .union
.intersection .difference (Jason's semantics: set operations sort their result in the
standard order of terms and keep each element once)."""

from __future__ import annotations

import functools
from collections.abc import Iterator
from typing import Any

from mrss.agentspeak.jrandom import RNG
from mrss.agentspeak.registry import IAContext
from mrss.agentspeak.stdlib import STDLIB
from mrss.agentspeak.stdlib.lists import list_arg
from mrss.agentspeak.terms import Term, compare, deref

_key = functools.cmp_to_key(compare)


def _seq(ctx: IAContext, t: Term) -> tuple[Term, ...] | str:
    t = deref(t)
    if type(t) is str:
        return t
    return list_arg(ctx, t)


@STDLIB.action(".empty", min_args=1, max_args=1)
def empty(ctx: IAContext, args: list[Any]) -> bool:
    """`.empty(L)`: L is the empty list (or the empty string)."""
    t = deref(args[0])
    if type(t) is str:
        return t == ""
    return type(t) is tuple and len(t) == 0


@STDLIB.action(".shuffle", min_args=2, max_args=2)
def shuffle(ctx: IAContext, args: list[Any]) -> bool:
    """`.shuffle(L, R)`: R holds the elements of L in a random order."""
    items = list(list_arg(ctx, args[0]))
    RNG.shuffle(items)
    return ctx.unify(args[1], tuple(items))


def _pieces(ctx: IAContext, args: list[Any], cuts: Iterator[tuple[int, int]]) -> Iterator[None]:
    whole = _seq(ctx, args[1])
    trail = ctx.runtime.trail
    for i, j in cuts:
        mark = len(trail)
        if ctx.unify(args[0], whole[i:j]):
            yield
        del trail[mark:]


@STDLIB.action(".prefix", min_args=2, max_args=2)
def prefix(ctx: IAContext, args: list[Any]) -> Iterator[None]:
    """`.prefix(P, L)`: P is a prefix of list (or string) L, longest first."""
    n = len(_seq(ctx, args[1]))
    return _pieces(ctx, args, ((0, j) for j in range(n, -1, -1)))


@STDLIB.action(".suffix", min_args=2, max_args=2)
def suffix(ctx: IAContext, args: list[Any]) -> Iterator[None]:
    """`.suffix(S, L)`: S is a suffix of list (or string) L, longest first."""
    n = len(_seq(ctx, args[1]))
    return _pieces(ctx, args, ((i, n) for i in range(n + 1)))


@STDLIB.action(".sublist", min_args=2, max_args=2)
def sublist(ctx: IAContext, args: list[Any]) -> Iterator[None]:
    """`.sublist(S, L)`: S is a contiguous part of L: the longest first, from the front
    (L itself, then its prefixes, then those of its tail, ...; `[]` last)."""
    n = len(_seq(ctx, args[1]))
    cuts = [(i, j) for i in range(n) for j in range(n, i, -1)] + [(0, 0)]
    return _pieces(ctx, args, iter(cuts))


def _set(ctx: IAContext, t: Term) -> list[Term]:
    items = sorted(list_arg(ctx, t), key=_key)
    return [x for i, x in enumerate(items) if i == 0 or compare(items[i - 1], x) != 0]


def _contains(items: list[Term], x: Term) -> bool:
    return any(compare(x, y) == 0 for y in items)


@STDLIB.action(".union", min_args=3, max_args=3)
def union(ctx: IAContext, args: list[Any]) -> bool:
    """`.union(A, B, R)`: R is the sorted set of the elements of A and B."""
    a = list_arg(ctx, args[0])
    b = list_arg(ctx, args[1])
    return ctx.unify(args[2], tuple(_set(ctx, a + b)))


@STDLIB.action(".intersection", min_args=3, max_args=3)
def intersection(ctx: IAContext, args: list[Any]) -> bool:
    """`.intersection(A, B, R)`: R is the sorted set of the elements of A also in B."""
    b = _set(ctx, args[1])
    return ctx.unify(args[2], tuple(x for x in _set(ctx, args[0]) if _contains(b, x)))


@STDLIB.action(".difference", min_args=3, max_args=3)
def difference(ctx: IAContext, args: list[Any]) -> bool:
    """`.difference(A, B, R)`: R is the sorted set of the elements of A not in B."""
    b = _set(ctx, args[1])
    return ctx.unify(args[2], tuple(x for x in _set(ctx, args[0]) if not _contains(b, x)))
