"""The agent's circumstance and the transitions of Jason's reasoning cycle.

Holds beliefs, plans, the event queue, intentions (a round-robin queue of runnable
ones; parked ones are not in it, so blocked intentions cost nothing per cycle), the
environment actions in progress and the `.wait` timers. `agent.Agent` drives it.
How environment actions go out to the host and come back is `hostactions`, the
`.wait` and `.at` timers are `timers`: their functions are `Runtime` methods.

Jason's transition rules (Bordini et al., "Programming Multi-Agent Systems in
AgentSpeak using Jason", formal semantics) and where each one is:

- SelEv (select an event): `Agent.step` takes the oldest event (`events`, FIFO; while
  an `[atomic]` intention runs, its own `atomic_events`; goal-state meta-events
  `^!g[state(S)]` are put at the front of `events`: see `goalstates`).
- RelPl (relevant plans): `PlanLibrary.index` (plans indexed by trigger operator,
  functor, arity and negation), then trigger unification, ApplPl (applicable plans)
  and SelAppl (select one), fused and lazy in one function per key compiled by
  `selection` (`PlanLibrary.selector`): contexts are tried in source order and the
  first applicable plan is taken; `Runtime.handle_event` calls it.
- AddIM (add the intended means): the end of `Runtime.handle_event`: pushed on the
  intention that posted the event, or on a new intention for an external event
  (with tail-recursion optimisation).
- SelInt (select an intention): `Agent.step`, round-robin over `runq` (runnable ones
  only; the `[atomic]` one alone while it runs).
- ExecInt (execute one formula): `Runtime.run_step`, which runs one compiled formula
  (`instructions.Instr.run`); environment actions leave through `start_action` and
  come back through `process_completion`.
- ClrInt (clear finished plans): `Runtime.pop_finished`.

One idea in one module: the transitions above share the circumstance they change and
call each other on the hot path (`intend_now` is AddIM taken early from ExecInt); a
method per file would make one cycle a walk across modules.
"""

from __future__ import annotations

import itertools
import logging
from collections import deque
from collections.abc import Callable, Hashable
from typing import Any

from mrss.agentspeak import goals, goalstates, hostactions, ownevent, timers
from mrss.agentspeak.beliefs import BeliefBase
from mrss.agentspeak.depth import DEPTH_ERROR, depth_message
from mrss.agentspeak.errors import AslRuntimeError
from mrss.agentspeak.formulas import Query, compile_query
from mrss.agentspeak.hostactions import Host as Host
from mrss.agentspeak.instructions import Jump
from mrss.agentspeak.intentions import (
    DROPPED,
    FINISHED,
    PENDING_EVENT,
    RUNNABLE,
    Event,
    IntendedMeans,
    Intention,
    IntentionState,
)
from mrss.agentspeak.ownevent import OwnEvent
from mrss.agentspeak.plans import Plan, PlanKey, PlanLibrary
from mrss.agentspeak.registry import IAContext, InternalAction, Registry
from mrss.agentspeak.terms import (
    ADD_ACH,
    DEL_ACH,
    DEL_BEL,
    SOURCE_PERCEPT,
    Struct,
    Term,
)
from mrss.agentspeak.unify import resolve

log = logging.getLogger("mrss.agentspeak")


class Extras:
    """The rarely used parts of the circumstance, kept off the agent object: CPython
    gives an object of more than about 30 attributes slower attribute access, which
    costs every reasoning cycle some 10% (measured with `mrss bench reasoner`)."""

    __slots__ = ("suspended_events", "ns_props", "context_errors", "society")

    def __init__(self) -> None:
        self.society: Any = None  # the `society.Society` the agent talks in, if any
        # the context errors of a selection by `Runtime.intend_now`, not warned there
        # (the event then goes through the queue, where they are warned once)
        self.context_errors: list[Any] = []
        self.suspended_events: list[Event] = []  # goal events held by `.suspend(G)`
        # `.namespace_set_prop`: namespace -> key text -> (key, value), in the order set
        self.ns_props: dict[str, dict[str, tuple[Term, Term]]] = {}


class Runtime:
    """State and transitions of one agent; not thread-safe (see `Agent`)."""

    def __init__(self, name: str, host: Host | None, registry: Registry,
                 clock: Callable[[], float], out: Callable[[str], None]) -> None:
        self.name = name
        self.host = host
        self.registry = registry
        self.clock = clock
        self.out = out
        self.bb = BeliefBase()
        self.plans = PlanLibrary()
        self.trail: list[Any] = []
        self.events: deque[Event] = deque()
        self.atomic_events: deque[Event] = deque()
        self.extras = Extras()
        self.runq: deque[Intention] = deque()
        self.intentions: dict[int, Intention] = {}
        self.pending_actions: dict[Hashable, Intention] = {}
        self.completed: deque[tuple[Hashable, bool, str | None, Term | None, str | None]] = \
            deque()
        self.open_actions: frozenset[str] = frozenset(getattr(host, "open_actions", ()))
        # `.wait` deadlines (intention, token) and `.at` events (None, the event)
        self.timers: list[tuple[float, int, Any, Any]] = []
        self.event_waiters: list[Intention] = []
        self.atomic: Intention | None = None
        self.cycle = 0
        # told when a belief stops being perceived (its source(percept) is gone), by a
        # percept removal or by the agent's own plans: the reasoner's percept ledger
        self.on_percept_gone: Callable[[Struct], None] | None = None
        # told when a goal fails and no -! plan handles it (its intention is dropped):
        # the goal's text, the error (`no_applicable`, `action_failed`, ...; None when the
        # failure named none) and the message with its file:line; the reasoner's alert
        self.on_goal_dropped: Callable[[str, str | None, str], None] | None = None
        self._ids = itertools.count(1)
        self._seq = itertools.count()

    # ------------------------------------------------------------------ intentions
    def new_intention(self) -> Intention:
        it = Intention(next(self._ids))
        self.intentions[it.id] = it
        return it

    def make_runnable(self, it: Intention) -> None:
        it.state = RUNNABLE
        if not it.in_queue and not it.suspended and not it.dropped and it is not self.atomic:
            it.in_queue = True
            self.runq.append(it)

    def finish(self, it: Intention, state: IntentionState = FINISHED) -> None:
        it.state = state
        self.intentions.pop(it.id, None)
        if self.atomic is it:
            self._clear_atomic()

    def _clear_atomic(self) -> None:
        it = self.atomic
        self.atomic = None
        if it is not None and it.state is RUNNABLE and not it.dropped:
            self.make_runnable(it)

    def context_error(self, plan: Plan, exc: BaseException) -> None:
        """A plan's context raised `exc` while selecting: warn; the next plan is tried."""
        if isinstance(exc, AslRuntimeError):
            what = exc.message
        elif isinstance(exc, RecursionError):
            self.warn(f"{plan.file}:{plan.line}: "
                      + depth_message(f"the context of {plan.trigger_text()}"))
            return
        else:
            what = str(exc)
        self.warn(f"{plan.file}:{plan.line}: error in the context of "
                  f"{plan.trigger_text()}: {what}")

    def warn(self, message: str) -> None:
        log.warning("[%s] %s", self.name, message)

    # ------------------------------------------------------------------ events
    def post(self, ev: Event) -> None:
        if self.event_waiters:
            goals.notify_waiters(self, ev.op, ev.lit)
        if ev.intention is not None and ev.intention is self.atomic:
            self.atomic_events.append(ev)
        else:
            self.events.append(ev)

    def post_subgoal(self, it: Intention, lit: Struct, tail: bool, line: int,
                     op: int = ADD_ACH) -> None:
        it.state = PENDING_EVENT
        it.line = line
        self.post(Event(op, lit, it, tail))
        if self.plans.meta and op == ADD_ACH:
            goalstates.emit(self, lit, goalstates.GoalState.PENDING)

    def post_goal(self, lit: Struct, it: Intention | None) -> None:
        self.post(Event(ADD_ACH, lit, it))
        if self.plans.meta:
            goalstates.emit(self, lit, goalstates.GoalState.PENDING)

    def belief_changed(self, op: int, lit: Struct, it: Intention | None,
                       now: bool = False) -> bool:
        """Post `+b`/`-b` if some plan or `.wait` could react; a body's own belief event
        is handled on top of its intention before its next step. With `now` (the body
        formula posts no other event), the event is handled at once when that is the
        same (`intend_now`): True then."""
        if op == DEL_BEL and self.on_percept_gone is not None:
            store = self.bb.store((lit.functor, len(lit.args), lit.neg))
            held = store.get(lit.args) if store is not None else None
            if held is None or SOURCE_PERCEPT not in held.annots:
                self.on_percept_gone(lit)
        key = (op, lit.functor, len(lit.args), lit.neg)
        if key in self.plans.index:
            if it is not None:
                if (now and not self.events and not self.event_waiters and self.atomic is None
                        and not self.plans.meta and ownevent.AT_ONCE
                        and self.intend_now(it, key, lit, False)):
                    return True
                it.state = PENDING_EVENT
            self.post(Event(op, lit, it))
        elif self.event_waiters:
            goals.notify_waiters(self, op, lit)
        return False

    def handle_event(self, ev: Event) -> None:
        """Select the first applicable plan for `ev` and intend it."""
        it = ev.intention
        if it is not None and (it.dropped or it.gen != ev.gen):
            return
        lit = ev.lit
        key = (ev.op, lit.functor, len(lit.args), lit.neg)
        plans = self.plans
        try:
            select = plans.selectors[key]
        except KeyError:
            select = plans.selector(key)
        # RelPl, ApplPl, SelAppl: the key's plans tried in order (`selection`)
        found = select(self, lit) if select is not None else False
        if type(found) is not tuple:
            goals.no_applicable_plan(self, ev, found)  # type: ignore[arg-type]
            return
        chosen, frame = found
        op = key[0]
        im = IntendedMeans(chosen, frame, lit, op)
        meta = plans.meta
        if meta and op == ADD_ACH:
            goalstates.emit(self, lit, goalstates.GoalState.EXECUTING)
        if it is None:
            it = self.new_intention()
        elif ev.tail:
            stack = it.stack
            if stack:
                top = stack[-1]
                tl = top.lit
                if (top.op == ADD_ACH and tl.functor == key[1] and len(tl.args) == key[2]
                        and top.fail_target is None and top.pc >= len(top.code)
                        and (DEL_ACH, tl.functor, key[2], tl.neg) not in plans.index):
                    if meta:
                        goalstates.emit_stack(self, it, goalstates.DONE, len(stack) - 1)
                    stack.pop()  # tail-recursion optimisation: replace, don't stack
        elif op == DEL_ACH:
            im.fail_target = ev.target
        it.stack.append(im)
        if chosen.atomic and self.atomic is None:
            self.atomic = it
        # make_runnable, inline
        it.state = RUNNABLE
        if not it.in_queue and not it.suspended and not it.dropped and it is not self.atomic:
            it.in_queue = True
            self.runq.append(it)

    def intend_now(self, it: Intention, key: PlanKey, lit: Struct, tail: bool,
                   own: OwnEvent | None = None) -> bool:
        """Handle the event `lit` of `key` (operator and predicate) that `it` posts (a
        sub-goal, or a belief change of its body) now, as the next cycle's deliberate
        phase would, when the caller has made sure that is the same: no other event is
        queued (so it would be the next one taken), no `.wait`, `[atomic]` intention or
        goal-state plan could tell the difference, and the formula posts no other event.
        False, with nothing done, when no plan is applicable or a context raised: the
        event then goes through the queue, where the failure and the warnings happen in
        their usual cycle. When True, the formula's step is over: the plan's first
        formula is the intention's next step (`run_step` clears nothing this time).
        `own`, when given, is the posting formula's `OwnEvent` for `key`, up to date."""
        plans = self.plans
        if own is not None:
            select = own.select
        else:
            try:
                select = plans.selectors[key]
            except KeyError:
                select = plans.selector(key)
        if select is None:
            return False
        errors = self.extras.context_errors
        found = select(self, lit, errors)
        if type(found) is not tuple or errors:
            errors.clear()
            return False
        chosen, frame = found
        stack = it.stack
        reused = False
        if tail and stack:
            top = stack[-1]
            tl = top.lit
            if (top.op == ADD_ACH and tl.functor == key[1] and len(tl.args) == key[2]
                    and top.fail_target is None and top.pc >= len(top.code)
                    and (own.no_fail_plan if own is not None and tl.neg is key[3] else
                         (DEL_ACH, tl.functor, key[2], tl.neg) not in plans.index)):
                # tail-recursion optimisation, as in `handle_event`: the finished frame
                # is replaced; its object, referenced nowhere else, is reused
                top.plan = chosen
                top.frame = frame
                top.pc = 0
                top.code = chosen.code
                top.lit = lit
                top.loops = None
                reused = True
        if not reused:
            stack.append(IntendedMeans(chosen, frame, lit, key[0]))
        if chosen.atomic:
            self.atomic = it
        self.make_runnable(it)
        return True

    # ------------------------------------------------------------------ acting
    def run_step(self, it: Intention) -> None:
        """Execute one body formula of `it`'s top plan, then clear finished plans."""
        stack = it.stack
        im = stack[-1]
        code = im.code
        pc = im.pc
        if pc < len(code):
            ins = code[pc]
            while type(ins) is Jump:
                im.pc = pc = ins.target
                if pc >= len(code):
                    break
                ins = code[pc]
            else:
                try:
                    intended = ins.run(self, it, im)
                except AslRuntimeError as exc:
                    if self.trail:
                        self.trail.clear()
                    goals.fail(self, it, exc.error, exc.message, im.plan.file, ins.line,
                               exc.annots)
                    return
                except RecursionError:
                    self.trail.clear()
                    goals.fail(self, it, DEPTH_ERROR, depth_message(ins.text()),
                               im.plan.file, ins.line)
                    return
                except (ArithmeticError, ValueError) as exc:  # e.g. an int too large to print
                    self.trail.clear()
                    goals.fail(self, it, "ia_failed", f"{ins.text()}: {exc}", im.plan.file,
                               ins.line)
                    return
                if self.trail:
                    self.trail.clear()
                if intended:  # a sub-goal's plan was pushed (`intend_now`): it is
                    return    # runnable, and its first step is the next cycle's
                if im.pc < len(im.code) and stack and stack[-1] is im:
                    # the plan goes on: nothing to clear (`pop_finished`, inline)
                    if (it.state is RUNNABLE and not it.dropped and not it.in_queue
                            and not it.suspended and it is not self.atomic):
                        it.in_queue = True
                        self.runq.append(it)
                    return
        if it.state is RUNNABLE and not it.dropped:
            self.pop_finished(it)

    def pop_finished(self, it: Intention) -> None:
        stack = it.stack
        atomic_gone = False
        while stack:
            im = stack[-1]
            if im.pc < len(im.code):
                break  # most calls: nothing to pop, no goal-state test
            if self.plans.meta:
                goalstates.popped(self, it, im)
            stack.pop()
            if im.plan.atomic:
                atomic_gone = True
            if im.fail_target is not None:
                del stack[im.fail_target:]
        if not stack:
            self.finish(it)
            return
        if atomic_gone and self.atomic is it and not any(m.plan.atomic for m in stack):
            self._clear_atomic()
        # make_runnable, inline
        it.state = RUNNABLE
        if not it.in_queue and not it.suspended and not it.dropped and it is not self.atomic:
            it.in_queue = True
            self.runq.append(it)

    # environment actions (`hostactions`): out to the host and back
    start_action = hostactions.start_action
    process_completion = hostactions.process_completion
    cancel_action = hostactions.cancel_action

    # ------------------------------------------------------------------ timers
    # `.wait` deadlines and `.at` events (`timers`)
    add_timer = timers.add_timer
    add_event_at = timers.add_event_at
    next_deadline = timers.next_deadline
    expire_timers = timers.expire_timers

    # ------------------------------------------------------------------ internal actions
    def ia_context(self, it: Intention | None, im: IntendedMeans | None,
                   frame: list[Any] | None, name: str) -> IAContext:
        return IAContext(self, it, im, frame, name)

    def ia_args(self, ia: InternalAction, args: tuple[Term, ...], queries: dict[int, Query],
                frame: list[Any] | None) -> list[Any]:
        if not ia.formula_args and not ia.raw_args:
            return [resolve(a, frame) for a in args]
        out: list[Any] = []
        for i, a in enumerate(args):
            if i in queries:
                out.append(queries[i])
            elif i in ia.raw_args:
                out.append(a)
            elif i in ia.formula_args:
                t = resolve(a, frame)
                out.append(compile_query(t, self.registry) if type(t) is Struct else t)
            else:
                out.append(resolve(a, frame))
        return out

    def drop(self, it: Intention, state: IntentionState = DROPPED, meta: bool = True) -> None:
        """Remove intention `it` wherever it is; its running action is cancelled. Its
        goals get the goal states dropped and finished (unless `meta` is False)."""
        if it.dropped:
            return
        if meta and self.plans.meta:
            goalstates.emit_stack(self, it, goalstates.ENDED)
        it.dropped = True
        self.cancel_action(it)
        if it.wait is not None:
            it.wait = None
            if it in self.event_waiters:
                self.event_waiters.remove(it)
        self.finish(it, state)
