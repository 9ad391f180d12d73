"""Goal failure, `.wait` wake-ups, and goal-level surgery on intentions.

Failure follows Jason: the nearest goal in the stack with a relevant `-!g` plan gets
`-!g[error(E), error_msg(M), code_src(F), code_line(L)]`; that plan runs on top of
the intention and, when it finishes, the stack unwinds through the failed goal and the
caller continues after `!g`. No handler: the intention is dropped with a warning, and
`Runtime.on_goal_dropped` is told of the goal that failed (`dropped_goal`).
"""

from __future__ import annotations

from collections.abc import Iterator
from typing import TYPE_CHECKING, Any

from mrss.agentspeak import goalstates
from mrss.agentspeak.depth import depth_message
from mrss.agentspeak.errors import AslRuntimeError
from mrss.agentspeak.goalstates import GoalState
from mrss.agentspeak.intentions import (
    PENDING_EVENT,
    RUNNABLE,
    WAITING,
    Event,
    IntendedMeans,
    Intention,
)
from mrss.agentspeak.termorder import sort_annots
from mrss.agentspeak.terms import (
    ADD_ACH,
    ADD_TEST,
    DEL_ACH,
    OP_TEXT,
    Struct,
    Term,
    Trigger,
    term_str,
    value,
)
from mrss.agentspeak.unify import undo, unify

if TYPE_CHECKING:
    from mrss.agentspeak.runtime import Runtime


def has_handler(rt: Runtime, lit: Struct) -> bool:
    """Whether goal `lit` has a `-!` plan of its predicate: Jason's findEventForFailure
    stops at the nearest goal with a candidate plan (PlanLibrary.hasCandidatePlan: the
    same functor and arity), whether or not its arguments, annotations or context will
    let one apply."""
    return bool(rt.plans.relevant(DEL_ACH, lit))


def fail(rt: Runtime, it: Intention, error: str | None, message: str, file: str, line: int,
         annots: tuple[Any, ...] = (), virtual: Struct | None = None,
         start: int | None = None) -> None:
    """Fail intention `it`: post `-!g` for the nearest handled goal, or drop it.

    `virtual` is a goal that failed before it got on the stack (no applicable plan);
    `start` is the stack index to search down from (default: the top)."""
    stack = it.stack
    it.wait = None
    target = -1
    goal: Struct | None = None
    if virtual is not None and has_handler(rt, virtual):
        target, goal = len(stack), virtual
    else:
        i = len(stack) - 1 if start is None else start
        while i >= 0:
            im = stack[i]
            if im.fail_target is not None:  # skip what an active -!g plan already covers
                i = im.fail_target - 1
                continue
            if im.op == ADD_ACH and has_handler(rt, im.lit):
                target, goal = i, im.lit
                break
            i -= 1
    where = f"{file}:{line}"
    if rt.plans.meta:
        _failed_states(rt, it, error, virtual, target if goal is not None else 0,
                       start, goal is None)
    if goal is None:
        failed = virtual if virtual is not None else (stack[-1].lit if stack else None)
        what = f" (+!{term_str(failed)})" if failed is not None else ""
        rt.warn(f"{where}: {message}; no -! plan handles it, intention {it.id} dropped{what}")
        given_up = dropped_goal(it, virtual)
        rt.drop(it, meta=False)
        if rt.on_goal_dropped is not None and given_up:
            rt.on_goal_dropped(given_up, error, f"{where}: {message}")
        return
    extra: tuple[Term, ...] = ()
    if error is not None:
        extra = (Struct("error", (Struct(error),)), Struct("error_msg", (f"{where}: {message}",)),
                 Struct("code_src", (file,)), Struct("code_line", (line,)))
    g: Any = value(goal)
    lit = Struct(g.functor, g.args, sort_annots(tuple(g.annots) + extra + tuple(annots)),
                 g.neg)
    it.gen += 1
    ev = Event(DEL_ACH, lit, it)
    ev.target = target
    ev.error = (error, message, file, line, annots)
    it.state = PENDING_EVENT
    rt.post(ev)


def dropped_goal(it: Intention, virtual: Struct | None) -> str:
    """The goal an intention dropped for a failure is given up on: the one that found no
    plan, else the innermost achievement goal of its stack, else its trigger (`+b`);
    without annotations."""
    if virtual is not None:
        return bare_text(virtual)
    for im in reversed(it.stack):
        if im.op == ADD_ACH:
            return bare_text(im.lit)
    return OP_TEXT[it.stack[-1].op] + bare_text(it.stack[-1].lit) if it.stack else ""


def bare_text(lit: Term) -> str:
    """A literal's text without its annotations (`b(1)`, not `b(1)[source(self)]`)."""
    g = value(lit)
    return term_str(Struct(g.functor, g.args, (), g.neg) if type(g) is Struct else g)


def _failed_states(rt: Runtime, it: Intention, error: str | None, virtual: Struct | None,
                   down_to: int, start: int | None, dropped: bool) -> None:
    """Goal states of a failure: `failed` for each goal that fails (the one that found
    no plan, then the stack from the top, or from `start`, down to the handled goal);
    when no `-!g` plan handles it, `finished` for each as its intention goes."""
    reason: Term = "" if error is None else Struct(
        error + "_plan" if error in ("no_relevant", "no_applicable") else error)
    top = len(it.stack) - 1 if start is None else start
    failing = ([virtual] if virtual is not None else []) + [
        it.stack[i].lit for i in range(top, down_to - 1, -1) if it.stack[i].op == ADD_ACH]
    for g in failing:
        goalstates.emit(rt, g, GoalState.FAILED, reason)
    if dropped:
        for i in range(len(it.stack) - 1, top, -1):  # above `start`: an active -!g plan
            if it.stack[i].op == ADD_ACH:
                goalstates.emit(rt, it.stack[i].lit, GoalState.FINISHED)
        for g in failing:
            goalstates.emit(rt, g, GoalState.FINISHED)
        for i in range(down_to - 1, -1, -1):
            if it.stack[i].op == ADD_ACH:
                goalstates.emit(rt, it.stack[i].lit, GoalState.FAILED, reason)
                goalstates.emit(rt, it.stack[i].lit, GoalState.FINISHED)
    elif virtual is not None and down_to == len(it.stack):
        goalstates.emit(rt, virtual, GoalState.FINISHED)


def no_applicable_plan(rt: Runtime, ev: Event, relevant: bool) -> None:
    """An event found no plan: goals fail, belief events just let the intention go on."""
    it = ev.intention
    what = "applicable" if relevant else "relevant"
    text = OP_TEXT[ev.op] + term_str(ev.lit)
    if ev.op == ADD_ACH:
        if it is None:
            rt.warn(f"no {what} plan for {text}; the goal is dropped")
            if rt.on_goal_dropped is not None:
                rt.on_goal_dropped(bare_text(ev.lit), "no_applicable" if relevant
                                   else "no_relevant", f"no {what} plan for {text}")
            return
        file = it.stack[-1].plan.file if it.stack else "<agent>"
        fail(rt, it, "no_applicable" if relevant else "no_relevant",
             f"no {what} plan for {text}", file, it.line, virtual=ev.lit)
    elif ev.op == ADD_TEST and it is not None:
        file = it.stack[-1].plan.file if it.stack else "<agent>"
        fail(rt, it, "test_goal_failed", f"test goal {text} failed", file, it.line)
    elif ev.op == DEL_ACH and it is not None:
        # Jason (TransitionSystem.generateGoalDeletionFromEvent): a `-!g` that no plan
        # applies to ends its intention ("Could not finish intention"), no cascade
        error, message, file, line, _ = ev.error
        rt.warn(f"{file}:{line}: {message}; no {what} plan for {text}, intention "
                f"{it.id} dropped")
        given_up = dropped_goal(it, None)
        rt.drop(it)
        if rt.on_goal_dropped is not None and given_up:
            rt.on_goal_dropped(given_up, error, f"{file}:{line}: {message}")
    elif it is not None:
        rt.pop_finished(it)


# ----------------------------------------------------------------------------- waits

def park(rt: Runtime, it: Intention, w: Any) -> None:
    """Suspend `it` on a `.wait` described by `w` (a WaitInfo)."""
    it.state = WAITING
    it.wait = w
    if w.trigger is not None or w.query is not None:
        rt.event_waiters.append(it)
    if w.deadline is not None:
        rt.add_timer(w.deadline, it, w.token)
    if rt.plans.meta:
        goalstates.emit_top(rt, it, GoalState.WAITING, wait_reason(it))


def wait_reason(it: Intention) -> Term:
    """Jason's reason of an intention in a `.wait` (wait.java's pendingReason):
    `wait(Id)[time(Ms)]`, `wait(Id)[Event's literal]`, `wait(Id)[condition]`."""
    w = it.wait
    what = value(w.what) if w is not None else Struct("condition")
    if type(what) is Trigger:
        annot: Term = what.lit
    elif type(what) is int or type(what) is float:
        annot = Struct("time", (what,))
    else:
        annot = what
    return Struct("wait", (it.id,), (annot,))


def resume(rt: Runtime, it: Intention, now: float) -> None:
    w = it.wait
    it.wait = None
    if it in rt.event_waiters:
        rt.event_waiters.remove(it)
    if w is not None and w.elapsed is not None:
        trail: list[Any] = []
        unify(w.elapsed, None, int(round((now - w.started) * 1000)), trail)
    if rt.plans.meta and not it.suspended:  # else `.resume` resumes it
        goalstates.emit_top(rt, it, GoalState.RESUMED)
    rt.pop_finished(it)


def wait_timeout(rt: Runtime, it: Intention, now: float) -> None:
    w = it.wait
    if w is not None and w.fail_on_timeout:
        if it in rt.event_waiters:
            rt.event_waiters.remove(it)
        it.state = RUNNABLE
        file = it.stack[-1].plan.file if it.stack else "<agent>"
        fail(rt, it, "wait_timeout", f"timeout in .wait({w.text})", file, it.line)
    else:
        resume(rt, it, now)


def notify_waiters(rt: Runtime, op: int, lit: Struct) -> None:
    """Wake intentions whose `.wait` trigger matches the event or whose condition holds."""
    trail = rt.trail
    for it in list(rt.event_waiters):
        w = it.wait
        if w is None:
            continue
        mark = len(trail)
        if w.trigger is not None:
            if w.trigger.op == op and unify(w.trigger.lit, None, lit, trail):
                del trail[mark:]
                resume(rt, it, rt.clock())
            else:
                undo(trail, mark)
        elif w.query is not None:
            try:
                for _ in w.query.solve(rt, w.frame):
                    del trail[mark:]
                    resume(rt, it, rt.clock())
                    break
            except (AslRuntimeError, RecursionError) as exc:
                undo(trail, mark)
                rt.warn(f"the condition of .wait of intention {it.id} cannot be checked: "
                        + (exc.message if isinstance(exc, AslRuntimeError)
                           else depth_message("the condition")))


# ----------------------------------------------------------------------------- goal surgery

def goal_index(rt: Runtime, it: Intention, g: Term) -> int:
    """Index of the topmost `+!g` intended means of `it` unifying with `g`, or -1."""
    trail = rt.trail
    for i in range(len(it.stack) - 1, -1, -1):
        im = it.stack[i]
        if im.op == ADD_ACH:
            mark = len(trail)
            ok = unify(g, None, im.lit, trail)
            undo(trail, mark)
            if ok:
                return i
    return -1


def intended(rt: Runtime, g: Term) -> Iterator[tuple[Intention, IntendedMeans]]:
    """Every (intention, intended means) whose goal unifies with `g`, bindings in place."""
    trail = rt.trail
    for it in list(rt.intentions.values()):
        for im in reversed(it.stack):
            if im.op == ADD_ACH:
                mark = len(trail)
                if unify(g, None, im.lit, trail):
                    yield it, im
                undo(trail, mark)


def _detach(rt: Runtime, it: Intention) -> None:
    """Stop whatever `it` is blocked on (action, wait, pending event) before surgery."""
    rt.cancel_action(it)
    if it.wait is not None:
        it.wait = None
        if it in rt.event_waiters:
            rt.event_waiters.remove(it)
    it.gen += 1


def succeed_goal(rt: Runtime, it: Intention, index: int) -> None:
    """Pop down to and including the goal at `index`; its caller continues."""
    _detach(rt, it)
    if rt.plans.meta:
        goalstates.emit_stack(rt, it, goalstates.DONE, index)
    del it.stack[index:]
    if not it.stack:
        rt.finish(it)
        return
    it.state = RUNNABLE
    rt.pop_finished(it)


def fail_goal(rt: Runtime, it: Intention, index: int) -> None:
    """Fail the goal at `index` (posting `-!g` without error annotations)."""
    _detach(rt, it)
    im = it.stack[index]
    it.state = RUNNABLE
    fail(rt, it, None, "goal failed by .fail_goal", im.plan.file, im.plan.line,
         start=index)


def succeed_event(rt: Runtime, ev: Event) -> None:
    """`.succeed_goal` of a goal still an event (taken out of the queue by the caller):
    the goal counts as achieved, and the intention that posted it, if any, goes on
    after `!g` (Jason's succeed_goal.dropInEvent)."""
    if rt.plans.meta:
        for state in goalstates.DONE:
            goalstates.emit(rt, ev.lit, state)
    it = ev.intention
    if it is not None and not it.dropped and it.gen == ev.gen:
        it.state = RUNNABLE
        rt.pop_finished(it)


def fail_event(rt: Runtime, ev: Event) -> None:
    """`.fail_goal` of a goal still an event (taken out of the queue by the caller): it
    becomes the event `-!g`, without error annotations (Jason's fail_goal.dropInEvent
    turns the trigger's operator into `-`). A sub-goal's `-!g` plan runs on top of its
    intention, which then goes on after `!g`; with no `-!g` plan the failure goes down
    the stack as any other."""
    it = ev.intention
    if it is None:
        if rt.plans.meta:
            goalstates.emit(rt, ev.lit, GoalState.FAILED)
        rt.post(Event(DEL_ACH, ev.lit, None))
        return
    if it.dropped or it.gen != ev.gen:
        return
    it.state = RUNNABLE
    file = it.stack[-1].plan.file if it.stack else "<agent>"
    fail(rt, it, None, "goal failed by .fail_goal", file, it.line, virtual=ev.lit)
