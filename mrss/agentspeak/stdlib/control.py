"""Intention and goal management: .wait .intend .desire .drop_* .succeed_goal .fail_goal
.suspend .resume -- with Jason's meaning (see AGENTSPEAK.md)."""

from __future__ import annotations

from collections import deque
from collections.abc import Iterator
from typing import Any

from mrss.agentspeak import goals, goalstates
from mrss.agentspeak.formulas import Query
from mrss.agentspeak.goalstates import GoalState
from mrss.agentspeak.intentions import RUNNABLE, Event, Intention, WaitInfo
from mrss.agentspeak.registry import IAContext
from mrss.agentspeak.stdlib import STDLIB
from mrss.agentspeak.terms import (
    ADD_ACH,
    GOAL_STATE,
    Struct,
    Term,
    Trigger,
    deref,
    is_number,
    term_str,
)
from mrss.agentspeak.unify import undo, unify


def _current(ctx: IAContext) -> Intention:
    if ctx.intention is None:
        raise ctx.error("needs a running intention (it cannot be used in a plan context)")
    return ctx.intention


@STDLIB.action(".wait", min_args=1, max_args=3, formula_args=(0,), body_only=True)
def wait(ctx: IAContext, args: list[Any]) -> bool:
    """`.wait(Ms)`, `.wait({+event})`, `.wait(Condition)`, each with an optional timeout
    (ms); on timeout the wait fails (`wait_timeout`) unless an elapsed-time variable is
    given as the third argument."""
    it = _current(ctx)
    rt = ctx.runtime
    what = args[0]
    now = rt.clock()
    w = WaitInfo(next(rt._seq), term_str(what) if not isinstance(what, Query) else "condition")
    w.started = now
    w.what = deref(what) if not isinstance(what, Query) else Struct("condition")
    if is_number(deref(what)):
        w.deadline = now + float(deref(what)) / 1000.0  # type: ignore[arg-type]
    else:
        if isinstance(what, Query):
            for _ in what.solve(rt, ctx.frame):
                return True  # already holds: go on (bindings kept)
            w.query = what
            w.frame = ctx.frame
        elif type(what) is Trigger:
            w.trigger = what
        else:
            raise ctx.error(f"cannot wait for {term_str(what)}")
        if len(args) >= 2:
            timeout = deref(args[1])
            if not is_number(timeout):
                raise ctx.error(f"the timeout must be a number, not {term_str(timeout)}")
            w.deadline = now + float(timeout) / 1000.0  # type: ignore[arg-type]
            w.fail_on_timeout = len(args) < 3
        if len(args) == 3:
            w.elapsed = args[2]
    goals.park(rt, it, w)
    return True


@STDLIB.action(".intend", min_args=1, max_args=1)
def intend(ctx: IAContext, args: list[Any]) -> Iterator[None]:
    """Holds for each goal `+!G` in any intention's stack (blocked ones included), but
    not in an intention suspended by `.suspend`: Jason's intend.java passes
    considerSuspended=false (`.desire` passes true)."""
    for it, _ in goals.intended(ctx.runtime, args[0]):
        if not it.suspended:
            yield


def _goal_events(ctx: IAContext) -> list[Event]:
    rt = ctx.runtime
    return [ev for ev in list(rt.atomic_events) + list(rt.events) + rt.extras.suspended_events
            if ev.op == ADD_ACH and (ev.intention is None or not ev.intention.dropped)]


@STDLIB.action(".desire", min_args=1, max_args=1)
def desire(ctx: IAContext, args: list[Any]) -> Iterator[None]:
    """Like `.intend`, and also goals still waiting in the event queue."""
    trail = ctx.runtime.trail
    for ev in _goal_events(ctx):
        mark = len(trail)
        if unify(args[0], None, ev.lit, trail):
            yield
        undo(trail, mark)
    for _ in goals.intended(ctx.runtime, args[0]):
        yield


def _matching(ctx: IAContext, g: Term) -> list[Intention]:
    return list(dict.fromkeys(it for it, _ in goals.intended(ctx.runtime, g)))


@STDLIB.action(".drop_intention", min_args=0, max_args=1)
def drop_intention(ctx: IAContext, args: list[Any]) -> bool:
    """Drop every intention with goal G (the whole intention; its running action is
    cancelled at the host); with no argument, the current intention."""
    targets = [_current(ctx)] if not args else _matching(ctx, args[0])
    for it in targets:
        ctx.runtime.drop(it)
    return True


def _drop_goal_events(ctx: IAContext, g: Term | None) -> None:
    rt = ctx.runtime
    trail = rt.trail
    held: deque[Event] = deque(rt.extras.suspended_events)
    for queue in (rt.events, rt.atomic_events, held):
        kept: deque[Event] = deque()
        for ev in queue:
            drop = False
            if ev.op == ADD_ACH:
                mark = len(trail)
                drop = g is None or unify(g, None, ev.lit, trail)
                undo(trail, mark)
            if drop:
                if rt.plans.meta:
                    for state in goalstates.ENDED:
                        goalstates.emit(rt, ev.lit, state)
                if ev.intention is not None:
                    rt.drop(ev.intention)
            else:
                kept.append(ev)
        queue.clear()
        queue.extend(kept)
    rt.extras.suspended_events[:] = held


@STDLIB.action(".drop_desire", min_args=1, max_args=1)
def drop_desire(ctx: IAContext, args: list[Any]) -> bool:
    """Remove goal G from the event queue and drop the intentions pursuing it."""
    _drop_goal_events(ctx, args[0])
    for it in _matching(ctx, args[0]):
        ctx.runtime.drop(it)
    return True


@STDLIB.action(".drop_event", min_args=1, max_args=1)
def drop_event(ctx: IAContext, args: list[Any]) -> bool:
    """Remove the events `+!D` from the set of events only (no event is produced)."""
    _drop_goal_events(ctx, args[0])
    return True


@STDLIB.action(".drop_all_events", max_args=0)
def drop_all_events(ctx: IAContext, args: list[Any]) -> bool:
    """Empty the set of events (the desires not yet intended); no event is produced."""
    rt = ctx.runtime
    for queue in (rt.events, rt.atomic_events):
        pending = list(queue)
        queue.clear()
        for ev in pending:
            if ev.intention is not None:  # a sub-goal's intention went with its event
                rt.drop(ev.intention)
    return True


def _drop_all_but_current(ctx: IAContext) -> None:
    """Drop every intention but the one running: Jason clears its running, pending and
    waiting intentions (Circumstance.clearRunningIntentions ...), and the intention that
    runs the action is none of these at that moment, so it goes on."""
    rt = ctx.runtime
    for it in list(rt.intentions.values()):
        if it is not ctx.intention:
            rt.drop(it)


@STDLIB.action(".drop_all_intentions", max_args=0)
def drop_all_intentions(ctx: IAContext, args: list[Any]) -> bool:
    """Drop every intention but the current one, which goes on (Jason's
    drop_all_intentions.java); the goal events of sub-goals go with their intentions."""
    _drop_all_but_current(ctx)
    return True


@STDLIB.action(".drop_all_desires", max_args=0)
def drop_all_desires(ctx: IAContext, args: list[Any]) -> bool:
    """`.drop_all_intentions` and every goal event too (Jason's drop_all_desires.java)."""
    _drop_goal_events(ctx, None)
    _drop_all_but_current(ctx)
    return True


def _surgery(ctx: IAContext, g: Term, op: Any, in_event: Any) -> bool:
    """Apply `op` to each intention with goal G, and `in_event` to each goal event `+!G`
    not yet intended (queued or held by `.suspend`), as Jason's succeed_goal.drop does
    for the events first."""
    rt = ctx.runtime
    trail = rt.trail
    held = rt.extras.suspended_events
    for queue in (rt.events, rt.atomic_events, held):
        hits = []
        for ev in queue:
            if ev.op == ADD_ACH:
                mark = len(trail)
                if unify(g, None, ev.lit, trail):
                    hits.append(ev)
                undo(trail, mark)
        for ev in hits:
            i = next(k for k, e in enumerate(queue) if e is ev)
            after = queue[i + 1] if i + 1 < len(queue) else None
            del queue[i]
            before = {id(e) for e in queue}
            in_event(rt, ev)
            if queue is not held:  # Jason changes the event in place: a `-!G` that
                _take_place(queue, before, after)  # replaces it keeps its turn
    for it in _matching(ctx, g):
        i = goals.goal_index(rt, it, g)
        if i >= 0 and not it.dropped:
            op(rt, it, i)
    return True


def _take_place(queue: Any, before: set[int], after: Event | None) -> None:
    """Move the events posted since `before` (goal-state meta-events aside, which go
    first anyway) back to where the event they replace was: just before `after`."""
    new = [e for e in queue if id(e) not in before and e.op != GOAL_STATE]
    at = next((k for k, e in enumerate(queue) if e is after), None)
    if not new or at is None:
        return
    for e in new:
        queue.remove(e)
    at = next(k for k, e in enumerate(queue) if e is after)
    for k, e in enumerate(new):
        queue.insert(at + k, e)


@STDLIB.action(".succeed_goal", min_args=1, max_args=1)
def succeed_goal(ctx: IAContext, args: list[Any]) -> bool:
    """Goal G is taken as achieved: its plans are popped, the caller goes on; a goal
    still an event is removed (its intention, if any, goes on after `!G`)."""
    return _surgery(ctx, args[0], goals.succeed_goal, goals.succeed_event)


@STDLIB.action(".fail_goal", min_args=1, max_args=1)
def fail_goal(ctx: IAContext, args: list[Any]) -> bool:
    """Goal G fails: `-!G` is posted (no error annotation); then the caller goes on. A
    goal still an event becomes the event `-!G` (Jason's fail_goal.dropInEvent)."""
    return _surgery(ctx, args[0], goals.fail_goal, goals.fail_event)


SUSPEND_REASON = Struct("suspend_ia")  # Jason's suspend.java
RESUME_REASON = Struct("resume_ia")  # Jason's resume.java


def _suspend_events(ctx: IAContext, g: Term) -> None:
    """Move the goal events `+!G` (and those of intentions pursuing G) out of the event
    queue until `.resume(G)`."""
    rt = ctx.runtime
    trail = rt.trail
    held: list[Event] = []
    for queue in (rt.events, rt.atomic_events):
        kept: deque[Event] = deque()
        for ev in queue:
            hit = False
            if ev.op == ADD_ACH:
                mark = len(trail)
                hit = unify(g, None, ev.lit, trail)
                undo(trail, mark)
            if not hit and ev.intention is not None:
                hit = goals.goal_index(rt, ev.intention, g) >= 0
            if hit:
                held.append(ev)
                if ev.intention is not None:
                    ev.intention.suspended = True
            else:
                kept.append(ev)
        queue.clear()
        queue.extend(kept)
    rt.extras.suspended_events.extend(held)
    if rt.plans.meta:  # Circumstance.addPendingEvent tells the goal's listeners
        for ev in held:
            if ev.op == ADD_ACH:
                goalstates.emit(rt, ev.lit, GoalState.SUSPENDED, SUSPEND_REASON)


def _suspend(ctx: IAContext, it: Intention) -> None:
    if not it.suspended:
        it.suspended = True
        if ctx.runtime.plans.meta:
            goalstates.emit_top(ctx.runtime, it, GoalState.SUSPENDED, SUSPEND_REASON)


@STDLIB.action(".suspend", min_args=0, max_args=1)
def suspend(ctx: IAContext, args: list[Any]) -> bool:
    """Suspend the intentions with goal G (or the current one), wherever they are
    (running, waiting for an action or a `.wait`, or their goal still an event), until
    `.resume(G)`; the goal state `suspended` is posted."""
    if not args:
        _suspend(ctx, _current(ctx))
        return True
    for it in _matching(ctx, args[0]):
        _suspend(ctx, it)
    _suspend_events(ctx, args[0])
    return True


@STDLIB.action(".resume", min_args=1, max_args=1)
def resume(ctx: IAContext, args: list[Any]) -> bool:
    """Resume the suspended intentions with goal G (an intention still waiting for its
    action or `.wait` goes on when that ends); the goal state `resumed` is posted."""
    rt = ctx.runtime
    for it in _matching(ctx, args[0]):
        if it.suspended:
            it.suspended = False
            if rt.plans.meta:
                goalstates.emit_top(rt, it, GoalState.RESUMED, RESUME_REASON)
            if it.state is RUNNABLE:
                rt.make_runnable(it)
    trail = rt.trail
    back: list[Event] = []
    for ev in list(rt.extras.suspended_events):
        hit = False
        if ev.op == ADD_ACH:
            mark = len(trail)
            hit = unify(args[0], None, ev.lit, trail)
            undo(trail, mark)
        if not hit and ev.intention is not None:
            hit = goals.goal_index(rt, ev.intention, args[0]) >= 0
        if hit:
            rt.extras.suspended_events.remove(ev)
            back.append(ev)
            if ev.intention is not None:
                ev.intention.suspended = False
            if rt.plans.meta and ev.op == ADD_ACH:  # resume.java: goalResumed, then
                goalstates.emit(rt, ev.lit, GoalState.RESUMED, RESUME_REASON)  # the
                goalstates.emit(rt, ev.lit, GoalState.PENDING)  # event is added again
    for ev in back:
        rt.post(ev)
    return True


def suspended_reason(it: Intention) -> Term | None:
    """Why `it` is not running, as Jason's .suspended finds it: `act` for an environment
    action (PA, searched first), the `.wait`'s reason (PI: a `.suspend` while waiting
    keeps it), `suspend_ia` for `.suspend`; None if it is running."""
    if it.action is not None:
        return Struct("act")
    if it.wait is not None:
        return goals.wait_reason(it)
    if it.suspended:
        return SUSPEND_REASON
    return None


@STDLIB.action(".suspended", min_args=1, max_args=2)
def suspended(ctx: IAContext, args: list[Any]) -> bool:
    """`.suspended(G, R)`: G is a goal of an intention that is not running -- waiting
    for an action, in a `.wait` or suspended -- and R the reason (`act`, `wait(Id)[..]`,
    `suspend_ia`). As Jason's suspended.java, only the first such intention is tried
    (intentions waiting for an action first), and a goal that is still an event is not
    one; `.suspended(G)` (MRSS) leaves out R."""
    g = deref(args[0])
    if type(g) is not Struct:
        raise ctx.error(f"the first argument must be a literal, not {term_str(g)}")
    found = [(it, suspended_reason(it)) for it in _matching(ctx, g)]
    found = ([f for f in found if f[0].action is not None]
             + [f for f in found if f[0].action is None and f[1] is not None])
    if not found:
        return False
    return len(args) == 1 or ctx.unify(args[1], found[0][1])  # type: ignore[arg-type]
