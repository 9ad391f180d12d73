"""Plan terms `{ @l +!g : c <- b }` as values: closing a template over a frame, and text.

In a plan body a plan term shares the enclosing plan's variables; `close` makes the
runtime value: bound variables are replaced by their values, free ones (and the free
variables inside those values) become the plan's own slots, numbered from 0.
"""

from __future__ import annotations

from dataclasses import replace
from typing import Any

from mrss.agentspeak.syntax import BodyItem, BodyNode, IfItem, LoopItem, PlanSrc
from mrss.agentspeak.terms import (
    OP_TEXT,
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
    term_str,
    value,
)

TRUE = Struct("true")


class _Closer:
    def __init__(self, frame: list[Any] | None) -> None:
        self.frame = frame
        self.slots: dict[object, Slot] = {}
        self.names: list[str] = []

    def new(self, key: object, name: str) -> Slot:
        s = self.slots.get(key)
        if s is None:
            s = self.slots[key] = Slot(len(self.names), name)
            self.names.append(name)
        return s

    def term(self, t: Term, runtime: bool = False) -> Term:
        tt = type(t)
        if tt is Slot:
            v = self.frame[t.index] if self.frame is not None else None  # type: ignore[union-attr, index]
            if v is None:
                return self.new(("slot", t.index), t.name)  # type: ignore[union-attr]
            return self.term(value(v), True)
        if tt is Var:
            v = value(t)
            if type(v) is Var:
                return self.new(id(v), v.name)
            return self.term(v, True)
        if tt is Struct:
            s: Struct = t  # type: ignore[assignment]
            if s.ground:
                return s
            return Struct(s.functor, tuple([self.term(a) for a in s.args]),
                          tuple([self.term(a) for a in s.annots]), s.neg)
        if tt is tuple:
            return tuple([self.term(a) for a in t])  # type: ignore[union-attr]
        if tt is PList:
            return PList(tuple([self.term(a) for a in t.items]),  # type: ignore[union-attr]
                         self.term(t.tail))  # type: ignore[union-attr]
        if tt is Expr:
            return Expr(t.op, tuple([self.term(a) for a in t.args]))  # type: ignore
        if tt is Trigger:
            return Trigger(t.op, self.term(t.lit))  # type: ignore[union-attr, arg-type]
        if tt is AnnotTail:
            return AnnotTail(self.term(t.tail))  # type: ignore[union-attr]
        if tt is VarAnnot:
            return VarAnnot(self.term(t.var),  # type: ignore[union-attr]
                            tuple([self.term(a) for a in t.annots]))  # type: ignore
        if tt is PlanTerm and not t.closed:  # type: ignore[union-attr]
            return PlanTerm(self.src(t.src), False)  # type: ignore[union-attr]
        return t

    def body(self, nodes: list[BodyNode]) -> list[BodyNode]:
        out: list[BodyNode] = []
        for n in nodes:
            if isinstance(n, BodyItem):
                out.append(BodyItem(n.kind, self.term(n.term), n.line, n.col))
            elif isinstance(n, IfItem):
                out.append(IfItem([(self.term(c), self.body(b)) for c, b in n.branches],
                                  None if n.else_body is None else self.body(n.else_body),
                                  n.line))
            else:
                out.append(LoopItem(n.kind, self.term(n.cond), self.body(n.body), n.line))
        return out

    def src(self, p: PlanSrc) -> PlanSrc:
        label = self.term(p.label) if p.label is not None else None
        trigger = self.term(p.trigger)
        context = self.term(p.context) if p.context is not None else None
        body = self.body(p.body)
        annots = tuple([self.term(a) for a in p.annots])
        return PlanSrc(label, p.op, trigger, context, body, p.line, 0,  # type: ignore[arg-type]
                       annots, anon_label=p.anon_label)


def close(t: PlanTerm, frame: list[Any] | None) -> PlanTerm:
    """The runtime value of plan-term template `t` in `frame`."""
    if t.closed:
        return t
    c = _Closer(frame)
    src = c.src(t.src)
    src.nslots = len(c.names)
    src.varnames = c.names
    return PlanTerm(src, True)


# --------------------------------------------------------------------------------- text

_PREFIX = {"achieve": "!", "achieve_new": "!!", "test": "?", "add": "+", "add_end": "+>",
           "del": "-", "replace": "-+"}


def _cond(t: Term) -> str:
    text = term_str(t)
    return text if text.startswith("(") and text.endswith(")") else f"({text})"


def _body_text(nodes: list[BodyNode]) -> str:
    parts: list[str] = []
    for n in nodes:
        if isinstance(n, BodyItem):
            parts.append(_PREFIX.get(n.kind, "") + term_str(n.term))
        elif isinstance(n, IfItem):
            text = " elif ".join(f"{_cond(c)} {{ {_body_text(b)} }}"
                                 for c, b in n.branches)
            if n.else_body is not None:
                text += f" else {{ {_body_text(n.else_body)} }}"
            parts.append("if " + text)
        else:
            parts.append(f"{n.kind} {_cond(n.cond)} {{ {_body_text(n.body)} }}")
    return "; ".join(parts)


def plan_text_unlabelled(p: PlanSrc) -> str:
    """A plan term's text without its label: what Jason's `==` on plans compares (its
    Plan.equals: the triggering event, the context (`true` as none) and the body)."""
    return plan_term_text(replace(p, label=None, annots=()))


def plan_term_text(p: PlanSrc) -> str:
    """Jason's text of a plan term: `{ @l[a] +!g(X) : c <- b1; b2 }`."""
    text = "{ "
    if p.label is not None:
        label = p.label
        if p.annots:
            label = Struct(label.functor, label.args, p.annots, label.neg)
        text += "@" + term_str(label) + " "
    text += OP_TEXT[p.op] + term_str(p.trigger)
    if p.context is not None and p.context != TRUE:  # Jason's Plan.toASString leaves
        text += " : " + term_str(p.context)           # out a context `true`
    if p.body:
        text += " <- " + _body_text(p.body)
    return text + " }"
