"""Intentions as data: `.intention(Id, State[, Stack[, current]])` and
`.current_intention(I)`, with Jason's shapes and order (the current intention first).

An intention's state is `running`, `suspended` (by `.suspend`), `waiting[action(A)]`
(an environment action at the host) or `waiting[reason(wait(W))]` (a `.wait`). Its
stack is a list, top first, of `im(Label, {Trigger}, Body, Bindings)`: the plan's label
annotated `code_line(L)`, `code_src(F)` and its sources, the event it handles, its body
as a string, and the variables bound so far as `map(Var, Value)`.
"""

from __future__ import annotations

from collections.abc import Iterator
from typing import Any

from mrss.agentspeak.intentions import IntendedMeans, Intention
from mrss.agentspeak.planterms import _body_text
from mrss.agentspeak.registry import IAContext
from mrss.agentspeak.stdlib import STDLIB
from mrss.agentspeak.stdlib.control import suspended_reason
from mrss.agentspeak.terms import Struct, Term, Trigger, Var, deref, term_str, value
from mrss.agentspeak.unify import undo, unify

RUNNING = Struct("running")
SUSPENDED = Struct("suspended")


def state_term(it: Intention) -> Term:
    """Jason's state of `it` (see the module docstring)."""
    if it.suspended:
        return SUSPENDED
    reason = suspended_reason(it)
    if reason is None:
        return RUNNING
    if it.action is not None:
        return Struct("waiting", (), (Struct("action", (it.action_lit,)),))
    return Struct("waiting", (), (Struct("reason", (reason,)),))


def _im_term(im: IntendedMeans) -> Term:
    plan = im.plan
    label = plan.plabel or Struct("p__0")
    annots = (Struct("code_line", (plan.line,)), Struct("code_src", (plan.file,)),
              *(Struct("source", (s,)) for s in plan.sources))
    body = _body_text(plan.src.body) if plan.src is not None else ""
    names = plan.varnames
    maps = tuple(Struct("map", (Var(names[i]), value(v)))
                 for i, v in enumerate(im.frame)
                 if v is not None and i < len(names) and names[i] != "_"
                 and type(value(v)) is not Var)
    return Struct("im", (Struct(label.functor, label.args, annots), Trigger(im.op, value(im.lit)),
                         body, maps))


def stack_term(it: Intention) -> Term:
    """The intended means of `it`, top first."""
    return tuple(_im_term(im) for im in reversed(it.stack))


def _order(it: Intention, current: Intention | None) -> tuple[int, int]:
    """Jason's order: the current intention, the running ones, those waiting for an
    action, those in a `.wait` or suspended; each group by age."""
    if it is current:
        group = 0
    elif it.suspended or it.wait is not None:
        group = 3
    elif it.action is not None:
        group = 2
    else:
        group = 1
    return group, it.id


def _current_of(ctx: IAContext) -> Intention:
    it = ctx.intention
    if it is None:
        raise ctx.error("there is no current intention here (a plan context of an "
                        "external event)")
    return it


@STDLIB.action(".intention", min_args=2, max_args=4)
def intention(ctx: IAContext, args: list[Any]) -> Iterator[None]:
    """`.intention(Id, State)`, `.intention(Id, State, Stack)`, and with a fourth
    argument `current`, the intention running it (its state is `running`)."""
    rt = ctx.runtime
    trail = rt.trail
    if len(args) == 4:
        which = deref(args[3])
        if not (type(which) is Struct and which.functor == "current" and not which.args):
            raise ctx.error(f"the fourth argument must be current, not {term_str(which)}")
        it = _current_of(ctx)
        mark = len(trail)
        if (unify(args[0], None, it.id, trail) and unify(args[1], None, RUNNING, trail)
                and unify(args[2], None, stack_term(it), trail)):
            yield
        undo(trail, mark)
        return
    for it in sorted(rt.intentions.values(), key=lambda i: _order(i, ctx.intention)):
        if it.dropped:
            continue
        mark = len(trail)
        if (unify(args[0], None, it.id, trail) and unify(args[1], None, state_term(it), trail)
                and (len(args) == 2 or unify(args[2], None, stack_term(it), trail))):
            yield
        undo(trail, mark)


@STDLIB.action(".current_intention", min_args=1, max_args=1)
def current_intention(ctx: IAContext, args: list[Any]) -> bool:
    """`.current_intention(I)`: I is `intention(Id, Stack)` of the intention running it.
    Deprecated in Jason 3, which warns at each use (current_intention.java): so does
    this, in the agent's output as `.log(warning, ...)`."""
    ctx.runtime.out(".current_intention( intention(I,S) ) was replaced by "
                    ".intention(I,_,S,current)")
    it = _current_of(ctx)
    return ctx.unify(args[0], Struct("intention", (it.id, stack_term(it))))
