"""Relevant and applicable plans of one trigger key, compiled to one Python function.

Jason's RelPl, ApplPl and SelAppl for an event are, per plan of the event's key in
source order: unify the trigger with the event, then look for a first solution of
the context; the first plan that passes is intended. `selector(plans, arity)` turns
that loop, for one key's plans, into one generated function
`select(rt, lit) -> (plan, frame) | relevant`: each plan's trigger binding is written
out for its shape (the event's arguments copied into the frame, compared with constant
arguments, or general unification), its context inlined from `closures` (conditions
as `if`s, belief queries as `for` loops over their solutions), so the per-plan tests
of the general loop (`select_general`, kept for keys whose code would be too large)
are decided once, at build time. Errors in a context are reported through
`Runtime.context_error` and the next plan is tried, exactly as the general loop does;
when the caller passes a list `errors`, each one is appended to it instead (not warned:
`Runtime.intend_now` then lets the event take the queue, where it is warned once).

The library builds a key's selector on first use and forgets them all when a plan
is added or removed (`PlanLibrary.selector`).
"""

from __future__ import annotations

from collections.abc import Callable
from typing import TYPE_CHECKING, Any

from mrss.agentspeak.closures import MAX_NODES, _conjuncts, _Gen, _TooBig, compiled
from mrss.agentspeak.errors import AslRuntimeError
from mrss.agentspeak.terms import OP_TEXT
from mrss.agentspeak.unify import undo, unify

if TYPE_CHECKING:
    from mrss.agentspeak.plans import Plan
    from mrss.agentspeak.runtime import Runtime
    from mrss.agentspeak.terms import Struct

# (rt, event literal[, errors]) -> (plan, frame), or whether some plan was relevant
Selector = Callable[..., "tuple[Plan, list[Any]] | bool"]

MAX_PLANS = 64  # a key with more plans is selected by the general loop
CONTEXT_ERRORS = (AslRuntimeError, RecursionError, ArithmeticError, ValueError)


def select_general(plans: list[Plan]) -> Selector:
    """The selection loop over `plans`, for any plan (no code generated)."""

    def select(rt: Runtime, lit: Struct,
               errors: list[Any] | None = None) -> tuple[Plan, list[Any]] | bool:
        trail = rt.trail
        mark0 = len(trail)
        relevant = False
        args = lit.args
        for plan in plans:
            if plan.pad is not None:  # the trigger's arguments are the first slots
                frame = [*args, *plan.pad]
            elif plan.const_args is not None and lit.ground:  # e.g. +!count(0)
                if args != plan.const_args:
                    continue
                frame = [None] * plan.nslots
            else:
                frame = [None] * plan.nslots
                slots = plan.arg_slots
                if slots is not None:
                    for i in range(len(slots)):
                        frame[slots[i]] = args[i]
                elif not unify(plan.trigger, frame, lit, trail):
                    undo(trail, mark0)
                    continue
            relevant = True
            if plan.context is None:
                del trail[mark0:]
                return plan, frame
            try:
                test = plan.test
                if test is not None:
                    if test(rt, frame):
                        del trail[mark0:]
                        return plan, frame
                else:
                    for _ in plan.context.solve(rt, frame):
                        del trail[mark0:]
                        return plan, frame
            except CONTEXT_ERRORS as exc:
                if errors is None:
                    rt.context_error(plan, exc)
                else:
                    errors.append(exc)
            undo(trail, mark0)
        return relevant

    return select


def _binding(g: _Gen, plan: Plan, p: str, arity: int) -> list[str]:
    """Lines binding the frame `f` from the event for `plan` (indented for the plan's
    one-pass `while` block: `break` leaves it as not relevant, its bindings undone
    after the block)."""
    pad = "        "
    if plan.pad is not None:
        items = [f"a{i}" for i in range(arity)] + ["None"] * len(plan.pad)
        return [f"{pad}f = [{', '.join(items)}{',' if len(items) == 1 else ''}]"]
    new = f"{pad}f = [None] * {plan.nslots}"
    if plan.arg_slots is not None:
        return [new] + [f"{pad}f[{s}] = a{i}" for i, s in enumerate(plan.arg_slots)]
    general = [new, f"{pad}if not _unify({p}.trigger, f, lit, trail):", f"{pad}    break"]
    if plan.const_args is not None:
        c = g.const(plan.const_args)
        return ([f"{pad}if lit.ground:", f"{pad}    if args != {c}:", f"{pad}        break",
                 f"{pad}    f = [None] * {plan.nslots}", f"{pad}else:"]
                + ["    " + line for line in general])
    return general


def _test(g: _Gen, plan: Plan, p: str) -> list[str]:
    """Lines testing `plan`'s context on `f` (inside the plan's `try`): return on the
    first solution, leave the block (`break`, or falling through) otherwise."""
    found = ("del trail[mark0:]", f"return {p}, f")
    if plan.context is None:
        return ["            " + line for line in found]
    parts = _conjuncts(plan.context)
    if len(parts) > MAX_NODES:
        raise _TooBig
    lines, _ = g.conjunction(parts, depth=3, fail="break", success=found)
    return lines


def selector(plans: list[Plan], arity: int) -> Selector:
    """One generated function selecting among `plans` (all of one key, of `arity`
    arguments), or the general loop when they are too many or too large."""
    if len(plans) > MAX_PLANS:
        return select_general(plans)
    g = _Gen()
    g.env.update(_unify=unify, _undo=undo, _ERRORS=CONTEXT_ERRORS)
    lines = ["def select(rt, lit, errors=None):", "    args = lit.args"]
    if arity:
        lines.append(f"    {''.join(f'a{i}, ' for i in range(arity))}= args")
    lines += ["    trail = rt.trail", "    mark0 = len(trail)", "    relevant = False"]
    try:
        for plan in plans:
            p = g.const(plan)
            lines.append("    while True:")
            lines += _binding(g, plan, p, arity)
            lines += ["        relevant = True", "        try:"]
            lines += _test(g, plan, p)
            lines += ["        except _ERRORS as exc:", "            if errors is None:",
                      f"                rt.context_error({p}, exc)", "            else:",
                      "                errors.append(exc)",
                      "        break",
                      "    if len(trail) != mark0:",  # what this plan bound, undone
                      "        _undo(trail, mark0)"]
        lines.append("    return relevant")
        first = plans[0]  # named for its key: profiles tell the keys apart
        name = f"<asl select {OP_TEXT[first.op]}{first.trigger.functor}/{arity}>"
        code = compiled("\n".join(lines) + "\n", name)
    except (_TooBig, RecursionError, SyntaxError):  # SyntaxError: blocks nested too deep
        return select_general(plans)
    exec(code, g.env)  # noqa: S102 -- our own generated code
    fn: Selector = g.env["select"]
    return fn
