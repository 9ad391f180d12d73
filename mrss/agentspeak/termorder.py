"""Jason's standard order of terms: `.sort`, `.min`/`.max`, sets, sorted listings and
the order of a literal's annotations.

As Jason 3.1's `compareTo` methods (asSyntax/NumberTermImpl, StringTermImpl,
ListTermImpl, Atom, VarTerm): numbers < strings < lists < literals < variables. Numbers
compare by value; strings as their quoted text; lists item by item (a list that is a
prefix of the other first, an open tail as a variable); literals by namespace, functor,
strong negation (positive first), their arguments item by item, arity, then their
annotations item by item and their number; variables by name. `compare` returns -1, 0
or 1. `sort_annots` and `add_annot` keep an annotation list as Jason's `Pred.setAnnots`
and `Pred.addAnnot` do: sorted, without duplicates, an open tail last.
"""

from __future__ import annotations

from mrss.agentspeak.terms import AnnotTail, PList, Struct, Term, deref


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


def _ns(functor: str) -> tuple[str, str]:
    ns, sep, name = functor.rpartition("::")
    return (ns, name) if sep else ("default", functor)


def compare(a: Term, b: Term) -> int:
    """Jason's order of two terms: -1, 0 or 1."""
    a = deref(a)
    b = deref(b)
    ra, rb = _rank(a), _rank(b)
    if ra != rb:
        return -1 if ra < rb else 1
    if ra == 0:
        return -1 if a < b else (1 if a > b else 0)  # type: ignore[operator]
    if ra == 1:
        qa, qb = f'"{a}"', f'"{b}"'
        return -1 if qa < qb else (1 if qa > qb else 0)
    if ra == 2:
        return _compare_lists(a, b)
    if ra == 3:
        sa: Struct = a  # type: ignore[assignment]
        sb: Struct = b  # type: ignore[assignment]
        if sa.functor != sb.functor:
            fa, fb = _ns(sa.functor), _ns(sb.functor)
            return -1 if fa < fb else 1
        if sa.neg != sb.neg:
            return 1 if sa.neg else -1
        c = _compare_seq(sa.args, sb.args)
        if c:
            return c
        aa = [x for x in sa.annots if type(x) is not AnnotTail]
        ab = [x for x in sb.annots if type(x) is not AnnotTail]
        return _compare_seq(tuple(aa), tuple(ab))
    na, nb = getattr(a, "name", ""), getattr(b, "name", "")
    return -1 if na < nb else (1 if na > nb else 0)


def _compare_lists(a: Term, b: Term) -> int:
    """Item by item; the list that ends first is smaller; an open tail is a variable."""
    while True:
        a, b = deref(a), deref(b)
        if type(a) not in (tuple, PList) or type(b) not in (tuple, PList):
            return compare(a, b)
        ia = a if type(a) is tuple else a.items  # type: ignore[union-attr]
        ib = b if type(b) is tuple else b.items  # type: ignore[union-attr]
        n = min(len(ia), len(ib))
        c = _compare_seq(ia[:n], ib[:n])
        if c:
            return c
        ra = _rest(a, n)
        rb = _rest(b, n)
        if ra == () or rb == ():
            return 0 if ra == rb else (-1 if ra == () else 1)
        a, b = ra, rb


def _rest(t: Term, n: int) -> Term:
    if type(t) is tuple:
        return t[n:]
    items = t.items  # type: ignore[union-attr]
    return PList(items[n:], t.tail) if n < len(items) else t.tail  # type: ignore[union-attr]


def _compare_seq(a: tuple[Term, ...], b: tuple[Term, ...]) -> int:
    """Item by item, then the shorter first."""
    for x, y in zip(a, b, strict=False):
        c = compare(x, y)
        if c:
            return c
    return 0 if len(a) == len(b) else (-1 if len(a) < len(b) else 1)


def add_annot(annots: tuple[Term, ...], annot: Term) -> tuple[Term, ...]:
    """`annots` with `annot` put in its sorted place, unless an equal one is there."""
    for i, x in enumerate(annots):
        if type(x) is AnnotTail:
            return annots[:i] + (annot,) + annots[i:]
        c = compare(annot, x)
        if c == 0:
            return annots
        if c < 0:
            return annots[:i] + (annot,) + annots[i:]
    return annots + (annot,)


def sort_annots(annots: tuple[Term, ...]) -> tuple[Term, ...]:
    """An annotation list in Jason's order: sorted, duplicates left out, a tail last."""
    if len(annots) < 2:
        return annots
    out: tuple[Term, ...] = ()
    for a in annots:
        out = add_annot(out, a) if type(a) is not AnnotTail else out + (a,)
    return out
