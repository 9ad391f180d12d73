"""Unification of a template (in a frame) with a runtime term, and template resolution.

Bindings are recorded on a trail -- a flat list of (frame, index) pairs, or (Var, -1)
for runtime variables -- so a backtracking search can undo them with `undo`.
Annotations follow Jason: the annotations of the first term must be a subset of the
annotations of the second (each one unifying with some annotation there).

One idea in one module: Jason's unifier (Unifier.unifiesNoUndo) is one recursion in
which terms, lists, annotation subsets and annotated variables call each other over the
same frames and trail; resolution reads those frames back. Cut apart, each piece would
import the others.
"""

from __future__ import annotations

import functools
from typing import Any

from mrss.agentspeak.arith import Number, apply_op
from mrss.agentspeak.errors import AslRuntimeError
from mrss.agentspeak.planterms import close
from mrss.agentspeak.terms import (
    AnnotTail,
    Expr,
    PlanTerm,
    PList,
    Slot,
    Struct,
    Term,
    Trigger,
    Var,
    VarAnnot,
    compare,
    deref,
    fresh_var,
    splice_annots,
    term_str,
    value,
)

_order = functools.cmp_to_key(compare)

Frame = list[Any]  # slot values: None (unbound) or runtime terms
Trail = list[Any]


def undo(trail: Trail, mark: int) -> None:
    """Undo every binding recorded after `mark`."""
    while len(trail) > mark:
        idx = trail.pop()
        obj = trail.pop()
        if idx < 0:
            obj.ref = None
        else:
            obj[idx] = None


def unify(t: Term, frame: Frame | None, r: Term, trail: Trail) -> bool:
    """Unify template `t` (its slots live in `frame`) with runtime term `r`."""
    tt = type(t)
    if tt is Slot:
        idx = t.index  # type: ignore[union-attr]
        v = frame[idx]  # type: ignore[index]
        if v is None:
            frame[idx] = r  # type: ignore[index]
            trail.append(frame)
            trail.append(idx)
            return True
        t = v
        tt = type(t)
    if tt is Var:
        t = deref(t)
        tt = type(t)
        if tt is Var:
            r = deref(r)
            if r is not t:
                tr = type(r)
                if ((tr is Struct and not r.ground) or tr is tuple  # type: ignore[union-attr]
                        or tr is PList) and occurs(t, r):  # type: ignore[arg-type]
                    raise _cyclic(t, r)  # type: ignore[arg-type]
                t.ref = r  # type: ignore[union-attr]
                trail.append(t)
                trail.append(-1)
            return True
    rt = type(r)
    if rt is Var:
        r = deref(r)
        rt = type(r)
        if rt is Var:
            v = resolve(t, frame)
            tv = type(v)
            if tv is VarAnnot:  # Jason: a free `X[a]`'s annotations are no subset of
                return False    # a free variable's (none)
            if ((tv is Struct and not v.ground) or tv is tuple  # type: ignore[union-attr]
                    or tv is PList) and occurs(r, v):  # type: ignore[arg-type]
                raise _cyclic(r, v)  # type: ignore[arg-type]
            r.ref = v  # type: ignore[union-attr]
            trail.append(r)
            trail.append(-1)
            return True
    if tt is Struct:
        if rt is not Struct:  # a free annotated variable on the runtime side
            return rt is VarAnnot and _unify_with_var_annot(t, frame, r, trail)  # type: ignore
        ts: Struct = t  # type: ignore[assignment]
        rs: Struct = r  # type: ignore[assignment]
        if ts.functor != rs.functor or ts.neg != rs.neg:
            return False
        targs = ts.args
        rargs = rs.args
        n = len(targs)
        if n != len(rargs):
            return False
        if ts.ground and rs.ground and not ts.annots:
            return targs == rargs
        for i in range(n):
            if not unify(targs[i], frame, rargs[i], trail):
                return False
        if ts.annots:
            return unify_annots(ts.annots, frame, rs.annots, trail)
        return True
    if tt is str:
        if rt is str:
            return t == r
        return rt is VarAnnot and _unify_with_var_annot(t, frame, r, trail)  # type: ignore
    if tt is int or tt is float:
        if rt is int or rt is float:
            return t == r
        return rt is VarAnnot and _unify_with_var_annot(t, frame, r, trail)  # type: ignore
    if tt is tuple or tt is PList:
        return _unify_lists(t, frame, r, trail)
    if tt is Expr:
        return unify(resolve(t, frame), None, r, trail)
    if tt is Trigger:
        return (rt is Trigger and t.op == r.op  # type: ignore[union-attr]
                and unify(t.lit, frame, r.lit, trail))  # type: ignore[union-attr]
    if tt is VarAnnot:
        return _unify_var_annot(t, frame, r, trail)  # type: ignore[arg-type]
    if tt is PlanTerm:  # equal when they read the same
        return rt is PlanTerm and (term_str(close(t, frame))  # type: ignore[arg-type]
                                   == term_str(r))
    return False


def occurs(v: Var, t: Term) -> bool:
    """Whether free variable `v` occurs in runtime term `t` (iterative: any depth)."""
    stack = [t]
    while stack:
        x = deref(stack.pop())
        tx = type(x)
        if x is v:
            return True
        if tx is Struct:
            if not x.ground:  # type: ignore[union-attr]
                stack.extend(x.args)  # type: ignore[union-attr]
                stack.extend(x.annots)  # type: ignore[union-attr]
        elif tx is tuple:
            stack.extend(x)  # type: ignore[arg-type]
        elif tx is PList:
            stack.extend(x.items)  # type: ignore[union-attr]
            stack.append(x.tail)  # type: ignore[union-attr]
        elif tx is AnnotTail:
            stack.append(x.tail)  # type: ignore[union-attr]
        elif tx is VarAnnot:
            stack.append(x.var)  # type: ignore[union-attr]
            stack.extend(x.annots)  # type: ignore[union-attr]
    return False


def _cyclic(v: Var, t: Term) -> AslRuntimeError:
    return AslRuntimeError(f"cyclic term: {v.name} would be bound to {term_str(t)}, which "
                           f"contains {v.name} (cyclic terms are not supported)",
                           error="cyclic_term")


def unify_annots(tannots: tuple[Term, ...], frame: Frame | None,
                 rannots: tuple[Term, ...], trail: Trail) -> bool:
    """Each annotation of the template unifies with some annotation of the runtime term;
    a tail (`[a|T]`) takes the annotations left over."""
    if len(tannots) > 1 or type(tannots[-1]) is AnnotTail:
        return _unify_annots_apart(tannots, frame, rannots, trail)
    for a in tannots:
        mark = len(trail)
        for b in rannots:
            if unify(a, frame, b, trail):
                break
            undo(trail, mark)
        else:
            return False
    return True


def _unify_annots_apart(tannots: tuple[Term, ...], frame: Frame | None,
                       rannots: tuple[Term, ...], trail: Trail) -> bool:
    """As Jason: each annotation takes a different one of the other side's (the first
    that unifies); a tail takes those left over."""
    if not rannots:
        return False  # as Jason: an annotation list never matches a literal without any
    left = [b for b in rannots if type(b) is not AnnotTail]
    tail = tannots[-1] if type(tannots[-1]) is AnnotTail else None
    for a in (tannots if tail is None else tannots[:-1]):
        for i, b in enumerate(left):
            mark = len(trail)
            if unify(a, frame, b, trail):
                del left[i]
                break
            undo(trail, mark)
        else:
            return False
    return tail is None or unify(tail.tail, frame, tuple(left), trail)


def _split(t: Term, frame: Frame | None) -> tuple[list[Term], Term | None]:
    """A list term as (items, open tail or None), following bound tails."""
    items: list[Term] = []
    tail: Term | None = t
    while True:
        if type(tail) is Slot:
            v = frame[tail.index]  # type: ignore[index]
            if v is None:
                return items, tail
            tail = v
        tail = deref(tail)  # type: ignore[arg-type]
        if type(tail) is tuple:
            items.extend(tail)
            return items, None
        if type(tail) is PList:
            items.extend(tail.items)
            tail = tail.tail
            continue
        return items, tail


def _unify_lists(t: Term, frame: Frame | None, r: Term, trail: Trail) -> bool:
    if type(r) is not tuple and type(r) is not PList:
        return type(r) is VarAnnot and _unify_with_var_annot(t, frame, r, trail)
    ti, ttail = _split(t, frame)
    ri, rtail = _split(r, None)
    n = min(len(ti), len(ri))
    for i in range(n):
        if not unify(ti[i], frame, ri[i], trail):
            return False
    rest_t = tuple(ti[n:])
    rest_r = tuple(ri[n:])
    if rest_t:
        if rtail is None:
            return False
        left: Term = rest_t if ttail is None else PList(rest_t, ttail)
        return unify(rtail, None, resolve(left, frame), trail)
    if rest_r:
        if ttail is None:
            return False
        return unify(ttail, frame, rest_r if rtail is None else PList(rest_r, rtail), trail)
    if ttail is None:
        return rtail is None or unify(rtail, None, (), trail)
    return unify(ttail, frame, () if rtail is None else rtail, trail)


def resolve(t: Term, frame: Frame | None) -> Term:
    """The runtime term for template `t` in `frame`: slots replaced by their values
    (unbound ones by fresh variables, remembered in the frame) and arithmetic evaluated."""
    tt = type(t)
    if tt is Struct:
        s: Struct = t  # type: ignore[assignment]
        if s.ground:
            return s
        if s.annots:
            annots = tuple([resolve(a, frame) for a in s.annots])
            if type(annots[-1]) is AnnotTail:
                annots = splice_annots(annots)
        else:
            annots = ()
        return Struct(s.functor, tuple([resolve(a, frame) for a in s.args]), annots, s.neg)
    if tt is Slot:
        v = frame[t.index]  # type: ignore[index, union-attr]
        if v is None:
            v = frame[t.index] = fresh_var(t.name)  # type: ignore[index, union-attr]
            return v
        return value(v)
    if tt is int or tt is str or tt is float:
        return t
    if tt is Expr:
        return evaluate(t, frame)
    if tt is Var:
        return value(t)
    if tt is tuple:
        return tuple([resolve(a, frame) for a in t])  # type: ignore[union-attr]
    if tt is PList:
        p: PList = t  # type: ignore[assignment]
        items = tuple([resolve(a, frame) for a in p.items])
        tail = resolve(p.tail, frame)
        if type(tail) is tuple:
            return items + tail
        if type(tail) is PList:
            return PList(items + tail.items, tail.tail)
        return PList(items, tail)
    if tt is Trigger:
        return Trigger(t.op, resolve(t.lit, frame))  # type: ignore
    if tt is AnnotTail:
        return AnnotTail(resolve(t.tail, frame))  # type: ignore[union-attr]
    if tt is VarAnnot:
        return _resolve_var_annot(t, frame)  # type: ignore[arg-type]
    if tt is PlanTerm:
        return close(t, frame)  # type: ignore[arg-type]
    return t


def _resolve_var_annot(t: VarAnnot, frame: Frame | None) -> Term:
    """`X[a]`: X's literal with the annotations added; a free X stays annotated."""
    v = resolve(t.var, frame)
    annots = tuple([resolve(a, frame) for a in t.annots])
    if annots and type(annots[-1]) is AnnotTail:
        annots = splice_annots(annots)
    if type(v) is Struct:
        merged = list(v.annots) + [a for a in annots if a not in v.annots]
        if len(merged) > 1 and type(merged[-1]) is not AnnotTail:
            merged.sort(key=_order)
        return Struct(v.functor, v.args, tuple(merged), v.neg)
    if type(v) is Var:
        return VarAnnot(v, annots)
    return v


def _unify_var_annot(t: VarAnnot, frame: Frame | None, r: Term, trail: Trail) -> bool:
    """Jason (Unifier.unifiesNoUndo): the annotations of `X[..]` must be a subset of the
    other literal's, and X takes that literal without its annotations. A free variable
    has no annotations, so a free `X[a]` never unifies with it; a number, a string, a
    list and an atom written as an argument or a list item (Jason's Atom class, which is
    no Pred) are taken with no test (`strict_var_annot` says where an atom is tested)."""
    r = deref(r)
    tr = type(r)
    if tr is VarAnnot:
        if not unify_annots(t.annots, frame, r.annots, trail):  # type: ignore[union-attr]
            return False
        return unify(t.var, frame, r.var, trail)  # type: ignore[union-attr]
    if tr is Var:
        v = t.var
        if type(v) is Slot:
            v = frame[v.index]  # type: ignore[index]
        return (v is not None and type(deref(v)) is not Var
                and unify(r, None, resolve(t, frame), trail))
    if tr is Struct:
        rs: Struct = r  # type: ignore[assignment]
        if rs.annots or rs.args or rs.neg:
            if t.annots and not unify_annots(t.annots, frame, rs.annots, trail):
                return False
            if rs.annots:
                r = Struct(rs.functor, rs.args, (), rs.neg)
    return unify(t.var, frame, r, trail)


def _unify_with_var_annot(t: Term, frame: Frame | None, r: VarAnnot, trail: Trail) -> bool:
    """Template `t` against a free `X[a]` on the runtime side: as Jason, t's annotations
    must be a subset of X's, and X takes t without its annotations."""
    v = resolve(t, frame)
    if type(v) is Struct:
        vs: Struct = v
        if vs.annots:
            if not _annots_into(vs.annots, r.annots, trail):
                return False
            v = Struct(vs.functor, vs.args, (), vs.neg)
    return unify(r.var, None, v, trail)


def _annots_into(annots: tuple[Term, ...], into: tuple[Term, ...], trail: Trail) -> bool:
    """Each of a literal's `annots` unifies with a different one of `into` (an annotated
    variable's); those left over go to `into`'s tail when it has one (Jason's
    Pred.hasSubsetAnnot: `a[x,y] = N[H|T]` gives H = x, T = [y])."""
    if not into or type(into[-1]) is not AnnotTail:
        return bool(into) and unify_annots(annots, None, into, trail)
    left = list(into[:-1])
    extra: list[Term] = []
    for a in annots:
        for i, b in enumerate(left):
            mark = len(trail)
            if unify(a, None, b, trail):
                del left[i]
                break
            undo(trail, mark)
        else:
            extra.append(a)
    return not extra or unify(into[-1].tail, None, tuple(extra), trail)


def strict_var_annot(left: Term, frame: Frame | None, right: Term) -> bool:
    """Whether `left = right` must fail before unifying: Jason's `W[a] = b` fails (the
    atom `b` at the top of `=` is a Pred without annotations), though `.member(W[a],
    [b])` binds W (an atom in a list is Jason's Atom class, not a Pred)."""
    if type(left) is not VarAnnot or not left.annots:
        return False
    r = deref(right)
    return (type(r) is Struct and not r.args and not r.annots
            and not r.neg)


def evaluate(t: Term, frame: Frame | None) -> Term:
    """Evaluate an arithmetic expression template to a number."""
    e: Expr = t  # type: ignore[assignment]
    if e.fn is not None:
        return e.fn(e, frame)
    args: list[Number] = []
    for a in e.args:
        v = resolve(a, frame)
        tv = type(v)
        if tv is int or tv is float:
            args.append(v)  # type: ignore[arg-type]
        elif tv is Var:
            raise AslRuntimeError(f"unbound variable {term_str(v)} in arithmetic expression "
                                  f"{term_str(t)}")
        else:
            raise AslRuntimeError(f"arithmetic on a non-number: {term_str(v)} in "
                                  f"{term_str(t)}")
    return apply_op(e.op, args)
