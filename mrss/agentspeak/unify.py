"""Unification of a template (in a frame) with a runtime term, and template resolution.

Bindings are recorded on a trail -- a flat list of (frame, index) pairs, or (Var, -1)
for runtime variables -- so a backtracking search can undo them with `undo`.
Annotations follow Jason: the annotations of the first term must be a subset of the
annotations of the second (each one unifying with some annotation there).
"""

from __future__ import annotations

from typing import Any

from mrss.agentspeak.arith import Number, apply_op
from mrss.agentspeak.errors import AslRuntimeError
from mrss.agentspeak.terms import (
    Expr,
    PList,
    Slot,
    Struct,
    Term,
    Trigger,
    Var,
    deref,
    fresh_var,
    term_str,
    value,
)

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
                t.ref = r  # type: ignore[union-attr]
                trail.append(t)
                trail.append(-1)
            return True
    rt = type(r)
    if rt is Var:
        r = deref(r)
        rt = type(r)
        if rt is Var:
            r.ref = resolve(t, frame)  # type: ignore[union-attr]
            trail.append(r)
            trail.append(-1)
            return True
    if tt is Struct:
        if rt is not Struct:
            return False
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
        return rt is str and t == r
    if tt is int or tt is float:
        return (rt is int or rt is float) and t == r
    if tt is tuple or tt is PList:
        return _unify_lists(t, frame, r, trail)
    if tt is Expr:
        return unify(resolve(t, frame), None, r, trail)
    if tt is Trigger:
        return (rt is Trigger and t.op == r.op  # type: ignore[union-attr]
                and unify(t.lit, frame, r.lit, trail))  # type: ignore[union-attr]
    return False


def unify_annots(tannots: tuple[Term, ...], frame: Frame | None,
                 rannots: tuple[Term, ...], trail: Trail) -> bool:
    """Each annotation of the template unifies with some annotation of the runtime term."""
    for a in tannots:
        mark = len(trail)
        for b in rannots:
            if unify(a, frame, b, trail):
                break
            undo(trail, mark)
        else:
            return False
    return True


def _split(t: Term, frame: Frame | None) -> tuple[list[Term], Term | None]:
    """A list term as (items, open tail or None), following bound tails."""
    items: list[Term] = []
    tail: Term | None = t
    while True:
        if type(tail) is Slot:
            v = frame[tail.index]  # type: ignore[index, union-attr]
            if v is None:
                return items, tail
            tail = v
        tail = deref(tail)  # type: ignore[arg-type]
        if type(tail) is tuple:
            items.extend(tail)  # type: ignore[arg-type]
            return items, None
        if type(tail) is PList:
            items.extend(tail.items)  # type: ignore[union-attr]
            tail = tail.tail  # type: ignore[union-attr]
            continue
        return items, tail


def _unify_lists(t: Term, frame: Frame | None, r: Term, trail: Trail) -> bool:
    if type(r) is not tuple and type(r) is not PList:
        return False
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
        return Struct(
            s.functor,
            tuple([resolve(a, frame) for a in s.args]),
            tuple([resolve(a, frame) for a in s.annots]) if s.annots else (),
            s.neg,
        )
    if tt is Slot:
        v = frame[t.index]  # type: ignore[index, union-attr]
        if v is None:
            v = frame[t.index] = fresh_var(t.name)  # type: ignore[index, union-attr]
            return v  # type: ignore[no-any-return]
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
            return items + tail  # type: ignore[operator]
        if type(tail) is PList:
            return PList(items + tail.items, tail.tail)  # type: ignore[union-attr]
        return PList(items, tail)
    if tt is Trigger:
        return Trigger(t.op, resolve(t.lit, frame))  # type: ignore
    return t


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
