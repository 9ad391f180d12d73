"""Annotating terms: .add_annot and .add_nested_source (each also maps over a list)."""

from __future__ import annotations

from typing import Any

from mrss.agentspeak.registry import IAContext
from mrss.agentspeak.stdlib import STDLIB
from mrss.agentspeak.termorder import add_annot as put_annot
from mrss.agentspeak.terms import Struct, Term, term_str, value


def _annotate(ctx: IAContext, t: Term, annot: Term) -> Term:
    if type(t) is tuple:
        return tuple(_annotate(ctx, x, annot) for x in t)
    if type(t) is not Struct:
        raise ctx.error(f"expected a literal or a list of literals, not {term_str(t)}")
    if annot in t.annots:
        return t
    return Struct(t.functor, t.args, put_annot(t.annots, annot), t.neg)


@STDLIB.action(".add_annot", min_args=3, max_args=3)
def add_annot(ctx: IAContext, args: list[Any]) -> bool:
    """`.add_annot(L, A, R)`: R is literal L (or each literal of list L) annotated A."""
    return ctx.unify(args[2], _annotate(ctx, value(args[0]), value(args[1])))


def _nest(ctx: IAContext, t: Term, source: Term) -> Term:
    if type(t) is tuple:
        return tuple(_nest(ctx, x, source) for x in t)
    if type(t) is not Struct:
        raise ctx.error(f"expected a literal or a list of literals, not {term_str(t)}")
    inner = tuple(a for a in t.annots if type(a) is Struct and a.functor == "source")
    rest = tuple(a for a in t.annots if a not in inner)
    src = Struct("source", (source,), inner)
    return Struct(t.functor, t.args, put_annot(rest, src), t.neg)


@STDLIB.action(".add_nested_source", min_args=3, max_args=3)
def add_nested_source(ctx: IAContext, args: list[Any]) -> bool:
    """`.add_nested_source(L, S, R)`: R is L annotated `source(S)`, the sources L had
    nested in it: `a[source(b)]` with `c` gives `a[source(c)[source(b)]]`."""
    return ctx.unify(args[2], _nest(ctx, value(args[0]), value(args[1])))
