"""The plan library as data: `.add_plan`, `.remove_plan`, `.relevant_plans`, `.plan_label`,
and the rules as data: `.relevant_rules`."""

from __future__ import annotations

from collections.abc import Iterator
from dataclasses import replace
from typing import Any

from mrss.agentspeak.compile import compile_plan
from mrss.agentspeak.errors import AslRuntimeError, AslSyntaxError
from mrss.agentspeak.parser import parse_program
from mrss.agentspeak.plans import SELF, Plan
from mrss.agentspeak.planterms import plan_term_text
from mrss.agentspeak.registry import IAContext
from mrss.agentspeak.stdlib import STDLIB
from mrss.agentspeak.syntax import PlanSrc
from mrss.agentspeak.termorder import sort_annots
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
    deref,
    fresh_var,
    term_str,
)
from mrss.agentspeak.unify import undo, unify


def _items(t: Term) -> list[Term]:
    t = deref(t)
    return [deref(x) for x in t] if type(t) is tuple else [t]


def _source_of(ctx: IAContext, t: Term) -> PlanSrc:
    if type(t) is PlanTerm:
        return t.src  # type: ignore[no-any-return]
    if type(t) is str:
        try:
            program = parse_program(t.strip().rstrip(".") + ".", "<plan>")
        except AslSyntaxError as exc:
            raise ctx.error(f"invalid plan {t!r}: {exc.problems[0].message}") from None
        if len(program.statements) == 1 and isinstance(program.statements[0], PlanSrc):
            return program.statements[0]
    raise ctx.error(f"expected a plan term or a string with a plan, not {term_str(t)}")


def _same(a: Plan, src: PlanSrc) -> bool:
    """Whether `src` is the plan `a` (read the same, label annotations aside)."""
    return bool(plan_term_text(replace(a.src, label=None, annots=()))
                == plan_term_text(replace(src, label=None, annots=())))


@STDLIB.action(".add_plan", min_args=1, max_args=3)
def add_plan(ctx: IAContext, args: list[Any]) -> bool:
    """`.add_plan(P)`, `.add_plan(P, Source)`, `.add_plan(P, Source, begin|end)`: P a plan
    term, a string or a list of them; the label is annotated `source(Source)`."""
    source = deref(args[1]) if len(args) > 1 else SELF
    where = deref(args[2]) if len(args) > 2 else Struct("end")
    if type(where) is not Struct or where.functor not in ("begin", "end") or where.args:
        raise ctx.error(f"the position must be begin or end, not {term_str(where)}")
    rt = ctx.runtime
    plans: list[Plan] = []
    for item in _items(args[0]):
        src = _source_of(ctx, item)
        if src.label is not None and src.label.functor.startswith("p__"):
            src = replace(src, label=None)  # an automatic label: the library gives a new one
        old = rt.plans.labelled(src.label) if src.label is not None else None
        if old is not None:
            if not _same(old, src):
                raise ctx.error(f"there already is a plan with label {old.plabel}")
            if source not in old.sources:  # the same plan again: one more source
                old.sources.append(source)
            continue
        try:
            plans.append(compile_plan(src, rt.registry, "<added plan>"))
        except AslRuntimeError as exc:
            raise ctx.error(exc.message) from None
    for plan in reversed(plans) if where.functor == "begin" else plans:
        rt.plans.add(plan, begin=where.functor == "begin", source=source)
    return True


@STDLIB.action(".remove_plan", min_args=1, max_args=2)
def remove_plan(ctx: IAContext, args: list[Any]) -> bool:
    """`.remove_plan(Label)`, `.remove_plan(Labels, Source)`: removes the source (default
    self) from each plan's label, and the plan once it has no source left. Labels of no
    plan are ignored, as in Jason."""
    rt = ctx.runtime
    source = deref(args[1]) if len(args) > 1 else SELF
    for label in _items(args[0]):
        if type(label) is str and label.startswith("@"):  # "@l1", as in the Jason book
            label = Struct(label[1:])
        if type(label) is not Struct:
            raise ctx.error(f"a label is a literal, not {term_str(label)}")
        plan = rt.plans.labelled(label)
        if plan is not None and source in plan.sources:
            plan.sources.remove(source)
            if not plan.sources:
                rt.plans.remove(plan)
    return True


def plan_term(plan: Plan, sources: bool) -> PlanTerm:
    """The plan as a term, labelled with its library label (annotated with its sources
    when `sources`)."""
    annots = tuple(plan.src.annots)
    if sources:
        annots = sort_annots(annots + tuple(Struct("source", (s,)) for s in plan.sources))
    return PlanTerm(replace(plan.src, label=plan.plabel, annots=annots), True)


def full_label(plan: Plan) -> Struct:
    """The plan's label as Jason gives it: its annotations and sources, sorted."""
    label: Struct = plan.plabel  # type: ignore[assignment]
    annots = tuple(plan.src.annots) + tuple(Struct("source", (s,)) for s in plan.sources)
    return Struct(label.functor, label.args, sort_annots(annots), label.neg)


@STDLIB.action(".relevant_plans", min_args=2, max_args=3)
def relevant_plans(ctx: IAContext, args: list[Any]) -> bool:
    """`.relevant_plans({+!g}, Plans)` and `.relevant_plans({+!g}, Plans, Labels)`: the
    plans whose trigger unifies with the event, in library order."""
    ev = deref(args[0])
    if type(ev) is not Trigger or type(deref(ev.lit)) not in (Struct, Var):
        raise ctx.error(f"expected a triggering event such as {{+!g}}, not {term_str(ev)}")
    lit = deref(ev.lit)
    rt = ctx.runtime
    trail = rt.trail
    found: list[Plan] = []
    if type(lit) is Var:  # `{+!_}`: every plan of that kind of event, as Jason's
        found = [p for p in rt.plans.plans if p.op == ev.op]
    for plan in rt.plans.relevant(ev.op, lit) or [] if type(lit) is Struct else []:
        mark = len(trail)
        if unify(plan.trigger, [None] * plan.nslots, lit, trail):
            found.append(plan)
        undo(trail, mark)
    if not ctx.unify(args[1], tuple(plan_term(p, True) for p in found)):
        return False
    if len(args) > 2:
        labels = tuple(full_label(p) for p in found if p.plabel is not None)
        return ctx.unify(args[2], labels)
    return True


@STDLIB.action(".relevant_plan", min_args=2, max_args=3)
def relevant_plan(ctx: IAContext, args: list[Any]) -> Iterator[None]:
    """`.relevant_plan({+!g}, Plan)`, `.relevant_plan({+!g}, Plan, Label)`: like
    `.relevant_plans`, one plan per solution."""
    ev = deref(args[0])
    if type(ev) is not Trigger or type(deref(ev.lit)) is not Struct:
        raise ctx.error(f"expected a triggering event such as {{+!g}}, not {term_str(ev)}")
    lit = deref(ev.lit)
    rt = ctx.runtime
    trail = rt.trail
    for plan in list(rt.plans.relevant(ev.op, lit) or []):  # type: ignore[arg-type]
        mark = len(trail)
        ok = unify(plan.trigger, [None] * plan.nslots, lit, trail)
        undo(trail, mark)
        if ok and ctx.unify(args[1], plan_term(plan, True)) and (
                len(args) < 3 or (plan.plabel is not None
                                  and ctx.unify(args[2], full_label(plan)))):
            yield
        undo(trail, mark)


@STDLIB.action(".list_plans", max_args=1)
def list_plans(ctx: IAContext, args: list[Any]) -> bool:
    """Print the plans of the library as source text, one per line (`.list_plans({+!g})`:
    those whose trigger unifies with the event), labelled with their sources."""
    rt = ctx.runtime
    ev = deref(args[0]) if args else None
    if ev is not None and type(ev) is not Trigger:
        raise ctx.error(f"expected a triggering event such as {{+!g}}, not {term_str(ev)}")
    trail = rt.trail
    for plan in list(rt.plans.plans):
        if ev is not None:
            if plan.op != ev.op:
                continue
            mark = len(trail)
            ok = unify(plan.trigger, [None] * plan.nslots, deref(ev.lit), trail)
            undo(trail, mark)
            if not ok:
                continue
        rt.out(plan_term_text(plan_term(plan, True).src)[2:-2] + ".")
    return True


@STDLIB.action(".plan_label", min_args=2, max_args=2)
def plan_label(ctx: IAContext, args: list[Any]) -> Iterator[None]:
    """`.plan_label(P, L)` as Jason's plan_label.java: with L given, P is the plan term of
    the plan labelled L (its label annotated with its sources); with P a plan term and L
    free, L is P's own label (left free for a plan term labelled `@_`); otherwise each
    plan of the library whose label and term unify with L and P, in library order."""
    plan_arg = deref(args[0])
    label = deref(args[1])
    rt = ctx.runtime
    if type(plan_arg) is Var and type(label) is not Var:
        if type(label) is not Struct:
            label = Struct(term_str(label))
        plan = rt.plans.labelled(label)
        if plan is not None and ctx.unify(args[0], plan_term(plan, True)):
            yield
        return
    if type(label) is Var and type(plan_arg) is PlanTerm:
        src = plan_arg.src
        if src.label is not None:
            own = Struct(src.label.functor, src.label.args, tuple(src.annots), src.label.neg)
            if ctx.unify(label, own):
                yield
        elif src.anon_label:  # `@_`: its label is a free variable, L stays free
            yield
        return
    trail = rt.trail
    for plan in list(rt.plans.plans):
        mark = len(trail)
        if ctx.unify(args[1], full_label(plan)) and ctx.unify(args[0], plan_term(plan, True)):
            yield
        undo(trail, mark)


def _fresh(t: Term, frame: list[Any]) -> Term:
    """Template `t` as a runtime term: slots become fresh variables (one per slot) and
    expressions stay unevaluated (a rule body is shown, not run)."""
    tt = type(t)
    if tt is Slot:
        slot: Slot = t  # type: ignore[assignment]
        v = frame[slot.index]
        if v is None:
            v = frame[slot.index] = fresh_var(slot.name)
        return v  # type: ignore[no-any-return]
    if tt is Struct:
        s: Struct = t  # type: ignore[assignment]
        if s.ground:
            return s
        return Struct(s.functor, tuple([_fresh(a, frame) for a in s.args]),
                      tuple([_fresh(a, frame) for a in s.annots]), s.neg)
    if tt is tuple:
        return tuple([_fresh(a, frame) for a in t])  # type: ignore[union-attr]
    if tt is PList:
        return PList(tuple([_fresh(a, frame) for a in t.items]),  # type: ignore[union-attr]
                     _fresh(t.tail, frame))  # type: ignore[union-attr]
    if tt is Expr:
        return Expr(t.op, tuple([_fresh(a, frame) for a in t.args]))  # type: ignore
    if tt is VarAnnot:
        return VarAnnot(_fresh(t.var, frame),  # type: ignore[union-attr]
                        tuple([_fresh(a, frame) for a in t.annots]))  # type: ignore
    if tt is AnnotTail:
        return AnnotTail(_fresh(t.tail, frame))  # type: ignore[union-attr]
    return t


@STDLIB.action(".relevant_rules", min_args=2, max_args=2)
def relevant_rules(ctx: IAContext, args: list[Any]) -> bool:
    """`.relevant_rules(p(_), Rules)`: the rules whose head unifies with the literal, as
    rule terms `{ p(X) :- q(X) }`, in program order."""
    lit = deref(args[0])
    if type(lit) is not Struct:
        raise ctx.error(f"expected a literal, not {term_str(lit)}")
    rt = ctx.runtime
    store = rt.bb.store(lit.key)
    trail = rt.trail
    found: list[Term] = []
    for rule in store.rules if store is not None else []:
        mark = len(trail)
        ok = unify(rule.head, [None] * rule.nslots, lit.with_annots(()), trail)
        undo(trail, mark)
        if ok and rule.src_body is not None:
            frame: list[Any] = [None] * rule.nslots
            head = _fresh(rule.head, frame)
            found.append(Struct(":-", (head, _fresh(rule.src_body, frame))))
    return ctx.unify(args[1], tuple(found))
