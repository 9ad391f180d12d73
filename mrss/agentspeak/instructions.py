"""Compiled plan-body formulas: one instruction object per formula, run one per step.

One idea in one module (~500 lines): the instruction set, one small class per formula
kind (as Jason's asSemantics keeps its body-literal cases together), so the
interpreter's whole repertoire is read in one place.

Each `run(rt, it, im)` executes the formula for intention `it` whose top intended
means is `im`, advances `im.pc` (or jumps), and raises `AslRuntimeError` to fail the
intention. `if`/`while`/`for` compile to conditional jumps; a `Jump` costs no step.
"""

from __future__ import annotations

from typing import TYPE_CHECKING, Any

from mrss.agentspeak import ownevent
from mrss.agentspeak.closures import Tester, resolver, tester
from mrss.agentspeak.errors import AslRuntimeError
from mrss.agentspeak.formulas import LiteralQuery, Query
from mrss.agentspeak.intentions import PENDING_EVENT, Event, IntendedMeans
from mrss.agentspeak.ownevent import OwnEvent, belief_event
from mrss.agentspeak.termorder import add_annot
from mrss.agentspeak.terms import (
    ADD_ACH,
    ADD_BEL,
    ADD_TEST,
    DEL_BEL,
    SOURCE_SELF,
    Struct,
    Term,
    Var,
    VarAnnot,
    is_ground,
    rename,
    term_str,
    value,
)
from mrss.agentspeak.unify import resolve, undo

if TYPE_CHECKING:
    from mrss.agentspeak.beliefs import BeliefBase, PredStore
    from mrss.agentspeak.intentions import Intention
    from mrss.agentspeak.registry import InternalAction
    from mrss.agentspeak.runtime import Runtime


class Instr:
    """One body formula."""

    __slots__ = ("line",)
    prefix = ""

    def __init__(self, line: int) -> None:
        self.line = line

    def run(self, rt: Runtime, it: Intention, im: IntendedMeans) -> bool | None:
        """Run the formula; True only when a sub-goal's plan was pushed at once
        (`Achieve`): the step is over (see `Runtime.run_step`)."""
        raise NotImplementedError

    def text(self) -> str:
        return self.prefix + term_str(getattr(self, "lit", "?"))


class Achieve(Instr):
    """`!g`: post a sub-goal on this intention; it waits until a plan is pushed."""

    __slots__ = ("lit", "tail", "res", "own", "self_call")
    prefix = "!"

    def __init__(self, lit: Term, line: int) -> None:
        super().__init__(line)
        self.lit = lit
        self.tail = False
        # the goal's trigger is its plan's own (same functor, arity and negation, `+!`):
        # in tail position, the tail-recursion rule then holds unless the plan was
        # entered for a failure (`fail_target`) or the goal has `-!` plans (set by
        # `compile.Compiler.plan`, with `tail`)
        self.self_call = False
        self.res = resolver(lit)
        # the plan-library key of the goal (`AchieveVar`'s is only known when it runs)
        self.own = OwnEvent((ADD_ACH, lit.functor, len(lit.args), lit.neg)) \
            if type(lit) is Struct else None

    def run(self, rt: Runtime, it: Intention, im: IntendedMeans) -> bool | None:
        lit: Any = self.res(im.frame)
        tail = self.tail
        im.pc = len(im.code) if tail else im.pc + 1
        plans = rt.plans
        if rt.event_waiters or rt.atomic is not None or plans.meta:
            rt.post_subgoal(it, lit, tail, self.line)
            return None
        events = rt.events
        # With no other event queued, the next cycle's deliberate phase would take this
        # one first: its plan is selected and pushed now (no Event, no queue round trip),
        # as `Runtime.intend_now` does, written out for a goal of a known key posted
        # by the top intended means `im`.
        if not events and ownevent.AT_ONCE:
            own: Any = self.own
            if own.lib is not plans or own.version != plans.version:
                own.refresh(plans)
            if tail and not self.self_call:
                if rt.intend_now(it, own.key, lit, tail, own):
                    return True
            elif (select := own.select) is not None:
                errors = rt.extras.context_errors
                found = select(rt, lit, errors)
                if type(found) is tuple and not errors:
                    chosen, frame = found
                    if tail and own.no_fail_plan and im.fail_target is None:
                        # tail-recursion optimisation: `im`, finished, is replaced
                        im.plan = chosen
                        im.frame = frame
                        im.pc = 0
                        im.code = chosen.code
                        im.lit = lit
                        im.loops = None
                    else:
                        it.stack.append(IntendedMeans(chosen, frame, lit, ADD_ACH))
                    if chosen.atomic:
                        rt.atomic = it
                    rt.make_runnable(it)
                    return True
                errors.clear()
        it.state = PENDING_EVENT  # `Runtime.post_subgoal` when nothing else is to be done
        it.line = self.line
        events.append(Event(ADD_ACH, lit, it, tail))
        return None


class AchieveNew(Instr):
    """`!!g`: a new intention for g; this one goes on at once."""

    __slots__ = ("lit",)
    prefix = "!!"

    def __init__(self, lit: Term, line: int) -> None:
        super().__init__(line)
        self.lit = lit

    def run(self, rt: Runtime, it: Intention, im: IntendedMeans) -> None:
        lit = resolve(self.lit, im.frame)
        im.pc += 1
        rt.post_goal(rename(lit), None)  # type: ignore[arg-type]


def goal_literal(t: Term, frame: Any) -> Struct:
    """The literal a goal variable (`!G`, `!!G`) stands for, annotated `source(self)`."""
    lit = resolve(t, frame)
    if type(lit) is not Struct:
        raise AslRuntimeError(f"the goal {term_str(t)} is {term_str(lit)}, not a literal"
                              if type(lit) is not Var and type(lit) is not VarAnnot else
                              f"unbound variable {term_str(t)} used as a goal")
    if not any(type(a) is Struct and a.functor == "source" for a in lit.annots):
        lit = Struct(lit.functor, lit.args, add_annot(lit.annots, SOURCE_SELF), lit.neg)
    return lit


class AchieveVar(Achieve):
    """`!G` with G a variable bound to the goal literal."""

    __slots__ = ()

    def run(self, rt: Runtime, it: Intention, im: IntendedMeans) -> None:
        lit = goal_literal(self.lit, im.frame)
        im.pc = len(im.code) if self.tail else im.pc + 1
        rt.post_subgoal(it, lit, self.tail, self.line)


class AchieveNewVar(AchieveNew):
    """`!!G` with G a variable bound to the goal literal."""

    __slots__ = ()

    def run(self, rt: Runtime, it: Intention, im: IntendedMeans) -> None:
        lit = goal_literal(self.lit, im.frame)
        im.pc += 1
        rt.post_goal(rename(lit), None)  # type: ignore[arg-type]


class TestGoal(Instr):
    """`?b` (or `?(formula)`, `?X[a]`): query the beliefs; if nothing matches, try `+?b`
    plans; else fail."""

    __slots__ = ("lit", "query")
    prefix = "?"

    def __init__(self, lit: Term, query: Query, line: int) -> None:
        super().__init__(line)
        self.lit = lit
        self.query = query

    def run(self, rt: Runtime, it: Intention, im: IntendedMeans) -> None:
        for _ in self.query.solve(rt, im.frame):
            im.pc += 1
            return
        lit = resolve(self.lit, im.frame)
        if type(lit) is Struct and rt.plans.has(ADD_TEST, lit.key):
            im.pc += 1
            rt.post_subgoal(it, lit, False, self.line, ADD_TEST)
            return
        raise AslRuntimeError(f"test goal ?{term_str(lit)} failed: no such belief",
                              error="test_goal_failed")


class AddBelief(Instr):
    """`+b` (in front) or `+>b` (at the end); annotated `source(self)`."""

    __slots__ = ("lit", "front", "res", "own", "bb", "store")
    prefix = "+"

    def __init__(self, lit: Struct, front: bool, line: int) -> None:
        super().__init__(line)
        self.lit = lit
        self.front = front
        self.res = resolver(lit)
        self.own = OwnEvent((ADD_BEL, lit.functor, len(lit.args), lit.neg))
        # the store of the literal's predicate in belief base `bb` (stores are never
        # replaced or dropped: kept for the agent that last ran this formula)
        self.bb: BeliefBase | None = None
        self.store: PredStore | None = None

    def run(self, rt: Runtime, it: Intention, im: IntendedMeans) -> bool | None:
        lit: Any = self.res(im.frame)
        if not lit.ground:
            lit = rename(lit)
        im.pc += 1
        bb = rt.bb
        if self.bb is not bb:
            self.store = bb._store(self.own.key[1:])
            self.bb = bb
        if bb.add(lit, self.front, self.store):
            return belief_event(rt, self.own, lit, it)
        return None


class DelBelief(Instr):
    """`-b`: remove the first matching belief (its `source(self)`); never fails."""

    __slots__ = ("lit", "query", "res", "own", "bb", "store")
    prefix = "-"

    def __init__(self, lit: Struct, line: int) -> None:
        super().__init__(line)
        self.lit = lit
        self.query = LiteralQuery(lit)
        self.res = resolver(lit)
        self.own = OwnEvent((DEL_BEL, lit.functor, len(lit.args), lit.neg))
        self.bb: BeliefBase | None = None  # as `AddBelief`'s, once the store exists
        self.store: PredStore | None = None

    def run(self, rt: Runtime, it: Intention, im: IntendedMeans) -> bool | None:
        frame = im.frame
        im.pc += 1
        lit: Any = self.res(frame)
        if not lit.ground:
            for _ in self.query.solve(rt, frame):
                break
            else:
                return None
            lit = self.res(frame)
        bb = rt.bb
        if self.bb is not bb:
            store = bb.store(self.own.key[1:])
            if store is None:
                return None  # no belief of the predicate: nothing to remove
            self.store = store
            self.bb = bb
        if bb.remove(lit, self.store):
            return belief_event(rt, self.own, lit, it)
        return None


class ReplaceBelief(Instr):
    """`-+b(X)`: remove the first `b(_)` with `source(self)`, then add `b(X)`."""

    __slots__ = ("lit",)
    prefix = "-+"

    def __init__(self, lit: Struct, line: int) -> None:
        super().__init__(line)
        self.lit = lit

    def run(self, rt: Runtime, it: Intention, im: IntendedMeans) -> None:
        lit: Any = resolve(self.lit, im.frame)
        if not lit.ground:
            lit = rename(lit)
        im.pc += 1
        store = rt.bb.store(lit.key)
        if store is not None:
            for b in store.facts():
                if SOURCE_SELF in b.annots:
                    old = Struct(b.functor, b.args, (SOURCE_SELF,), b.neg)
                    if rt.bb.remove(old):
                        rt.belief_changed(DEL_BEL, old, it)
                    break
        if rt.bb.add(lit, True):
            rt.belief_changed(ADD_BEL, lit, it)


def _first_free(t: Term) -> Var | None:
    t = value(t)
    if type(t) is Var:
        return t
    if type(t) is Struct:
        for a in t.args + t.annots:
            v = _first_free(a)
            if v is not None:
                return v
    if type(t) is tuple:
        for a in t:
            v = _first_free(a)
            if v is not None:
                return v
    return None


class Action(Instr):
    """An environment action: sent to the host; the intention waits for the outcome."""

    __slots__ = ("lit", "res")

    def __init__(self, lit: Struct, line: int) -> None:
        super().__init__(line)
        self.lit = lit
        self.res = resolver(lit)

    def run(self, rt: Runtime, it: Intention, im: IntendedMeans) -> None:
        lit: Any = self.res(im.frame)
        if not lit.ground and lit.functor not in rt.open_actions and not is_ground(lit):
            free = _first_free(lit)
            raise AslRuntimeError(f"unbound variable {term_str(free) if free else '?'} in "
                                  f"action {term_str(lit)}", error="action_failed")
        im.pc += 1
        rt.start_action(it, lit, self.line)


class CallIA(Instr):
    """An internal action `.name(args)`; its first solution's bindings are kept."""

    __slots__ = ("ia", "args", "queries", "lit")

    def __init__(self, ia: InternalAction, lit: Struct, queries: dict[int, Query],
                 line: int) -> None:
        super().__init__(line)
        self.ia = ia
        self.lit = lit
        self.args = lit.args
        self.queries = queries

    def run(self, rt: Runtime, it: Intention, im: IntendedMeans) -> None:
        ia = self.ia
        frame = im.frame
        args = rt.ia_args(ia, self.args, self.queries, frame)
        im.pc += 1
        res = ia.fn(rt.ia_context(it, im, frame, ia.name), args)
        if res is None or res is True:
            return
        if res is not False:
            for _ in res:
                return
        raise AslRuntimeError(f"{ia.name} failed", error="ia_failed")


class Constraint(Instr):
    """A relational formula in a body, e.g. `X = Y + 1` or `N > 0`: fails if false."""

    __slots__ = ("query", "lit", "test")

    def __init__(self, query: Query, lit: Term, line: int) -> None:
        super().__init__(line)
        self.query = query
        self.lit = lit
        self.test = tester(query)

    def run(self, rt: Runtime, it: Intention, im: IntendedMeans) -> None:
        if _holds(self.query, self.test, rt, im.frame):
            im.pc += 1
            return
        raise AslRuntimeError(f"constraint {term_str(self.lit)} does not hold",
                              error="constraint_failed")


def _holds(query: Query, test: Tester | None, rt: Runtime, frame: Any) -> bool:
    """Whether `query` has a solution, its first solution's bindings kept (none left
    when it has none): the compiled `test` if there is one, else the query."""
    if test is None:
        for _ in query.solve(rt, frame):
            return True
        return False
    trail = rt.trail
    mark = len(trail)
    if test(rt, frame):
        return True
    undo(trail, mark)  # a condition that held before one that failed
    return False


class Jump(Instr):
    """Go to `target` (free: executed as part of the next step)."""

    __slots__ = ("target",)

    def __init__(self, target: int, line: int) -> None:
        super().__init__(line)
        self.target = target

    def text(self) -> str:
        return f"jump {self.target}"


class JumpUnless(Instr):
    """`if`/`elif` condition: on its first solution go on (bindings kept), else jump."""

    __slots__ = ("query", "target", "lit", "keyword", "test")

    def __init__(self, query: Query, lit: Term, line: int, keyword: str = "if") -> None:
        super().__init__(line)
        self.query = query
        self.lit = lit
        self.target = -1
        self.keyword = keyword
        self.test = tester(query)

    def run(self, rt: Runtime, it: Intention, im: IntendedMeans) -> None:
        if _holds(self.query, self.test, rt, im.frame):
            im.pc += 1
            return
        im.pc = self.target

    def text(self) -> str:
        return f"{self.keyword} ({term_str(self.lit)})"


class WhileTest(Instr):
    """`while (c)`: each round starts from the bindings before the loop (Jason's loop)."""

    __slots__ = ("query", "target", "lit", "test")

    def __init__(self, query: Query, lit: Term, line: int) -> None:
        super().__init__(line)
        self.query = query
        self.lit = lit
        self.target = -1
        self.test = tester(query)

    def run(self, rt: Runtime, it: Intention, im: IntendedMeans) -> None:
        frame = im.frame
        loops = im.loops
        if loops and loops[-1][0] is self:
            backup = loops[-1][1]
            frame[:] = backup
        else:
            backup = frame.copy()
            if loops is None:
                loops = im.loops = []
            loops.append([self, backup])
        if _holds(self.query, self.test, rt, frame):
            im.pc += 1
            return
        loops.pop()
        frame[:] = backup
        im.pc = self.target

    def text(self) -> str:
        return f"while ({term_str(self.lit)})"


class ForNext(Instr):
    """`for (c)`: all solutions are found first; the body runs once per solution."""

    __slots__ = ("query", "target", "lit")

    def __init__(self, query: Query, lit: Term, line: int) -> None:
        super().__init__(line)
        self.query = query
        self.lit = lit
        self.target = -1

    def run(self, rt: Runtime, it: Intention, im: IntendedMeans) -> None:
        frame = im.frame
        loops = im.loops
        if loops and loops[-1][0] is self:
            state = loops[-1]
        else:
            backup = frame.copy()
            trail = rt.trail
            mark = len(trail)
            solutions = [[None if v is None else value(v) for v in frame]
                         for _ in self.query.solve(rt, frame)]
            undo(trail, mark)
            state = [self, backup, iter(solutions)]
            if loops is None:
                loops = im.loops = []
            loops.append(state)
        nxt = next(state[2], None)
        if nxt is None:
            loops.pop()
            frame[:] = state[1]
            im.pc = self.target
        else:
            frame[:] = nxt
            im.pc += 1

    def text(self) -> str:
        return f"for ({term_str(self.lit)})"


GOAL_OPS = (ADD_ACH, ADD_TEST)
