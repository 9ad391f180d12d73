"""Jason's standard order of terms: `.sort`, `.min`/`.max`, sets and sorted listings.

The rules: numbers < strings < lists < literals < variables. Numbers and strings
compare by value; lists (open ones with their tail as the last item) by length, then
item by item; literals by strong negation (positive first), arity, functor, then their
arguments item by item, then the number of annotations and the annotations item by
item; variables (and anything else) by name. `compare` returns -1, 0 or 1.
"""

from __future__ import annotations

from mrss.agentspeak.terms import PList, Struct, Term, deref


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
        return t
    return t.items + (t.tail,)  # type: ignore


def _compare_seq(a: tuple[Term, ...], b: tuple[Term, ...]) -> int:
    for x, y in zip(a, b, strict=False):
        c = compare(x, y)
        if c:
            return c
    return 0 if len(a) == len(b) else (-1 if len(a) < len(b) else 1)
