"""Goal-state meta-events (Jason 3): `^!g[state(S)[reason(R)]]`.

Each change in the state of an achievement goal `g` posts the event `^!g` with the
annotation `state(S)[reason(R)]`, but only when some plan's trigger is `^!` of that
predicate (so a program without `^!` plans pays nothing but one test). As in Jason,
meta-events go before the other events (first come, first served among themselves)
and a plan for one runs as a new intention. They are kept at the front of the event
queue (no queue of their own: the cycle pays nothing for them).

The states and when each is posted (the reason is `""` unless said):

- pending: the event `+!g` is posted (by `!g`, `!!g`, an initial or external goal);
- executing: a plan for `+!g` is selected;
- waiting: the intention, with `g` on top, waits: reason `action(A)` for an
  environment action, `wait(W)` for `.wait(W)`;
- suspended: `.suspend` suspends it (reason `suspend`);
- resumed: the action ends, the `.wait` ends, or `.resume` resumes it;
- achieved: its plan finishes (or `.succeed_goal`);
- failed: it fails, the reason being the error (`ia_failed`, `action_failed`, ...;
  `no_relevant_plan`, `no_applicable_plan` when no plan is found);
- dropped: its intention or desire is dropped (`.drop_intention`, `.drop_desire`, ...);
- finished: after achieved, failed (once its `-!g` plan, if any, is done) or dropped.
"""

from __future__ import annotations

import enum
from typing import TYPE_CHECKING

from mrss.agentspeak.intentions import Event
from mrss.agentspeak.termorder import add_annot
from mrss.agentspeak.terms import ADD_ACH, GOAL_STATE, Struct, Term, value

if TYPE_CHECKING:
    from mrss.agentspeak.intentions import IntendedMeans, Intention
    from mrss.agentspeak.runtime import Runtime


class GoalState(enum.Enum):
    """Jason 3's goal states (GoalListener.GoalStates)."""

    PENDING = "pending"
    EXECUTING = "executing"
    WAITING = "waiting"
    SUSPENDED = "suspended"
    RESUMED = "resumed"
    ACHIEVED = "achieved"
    FAILED = "failed"
    DROPPED = "dropped"
    FINISHED = "finished"


_STATES = {s: Struct(s.value) for s in GoalState}


def emit(rt: Runtime, goal: Struct, state: GoalState, reason: Term = "") -> None:
    """Post `^!goal[state(S)[reason(R)]]` if some plan could handle it."""
    g = value(goal)
    if type(g) is not Struct:
        return
    if (GOAL_STATE, g.functor, len(g.args), g.neg) not in rt.plans.index:
        return
    annot = Struct("state", (_STATES[state],), (Struct("reason", (value(reason),)),))
    lit = Struct(g.functor, g.args, add_annot(tuple(g.annots), annot), g.neg)
    events = rt.events  # before the other events, after the meta-events already there
    i = 0
    while i < len(events) and events[i].op == GOAL_STATE:
        i += 1
    events.insert(i, Event(GOAL_STATE, lit, None))


def top_goal(it: Intention) -> Struct | None:
    """The goal on top of `it`'s stack, if the top plan is for an achievement goal."""
    if it.stack:
        im = it.stack[-1]
        if im.op == ADD_ACH:
            return im.lit
    return None


def emit_top(rt: Runtime, it: Intention, state: GoalState, reason: Term = "") -> None:
    """`emit` for the goal on top of `it` (Jason looks at the top intended means)."""
    g = top_goal(it)
    if g is not None:
        emit(rt, g, state, reason)


def emit_stack(rt: Runtime, it: Intention, states: tuple[GoalState, ...],
               start: int = 0, reason: Term = "") -> None:
    """`emit` each of `states` for every goal of `it`'s stack from the top down to
    index `start`."""
    for i in range(len(it.stack) - 1, start - 1, -1):
        im = it.stack[i]
        if im.op == ADD_ACH:
            for s in states:
                emit(rt, im.lit, s, reason)


ENDED = (GoalState.DROPPED, GoalState.FINISHED)
DONE = (GoalState.ACHIEVED, GoalState.FINISHED)


def popped(rt: Runtime, it: Intention, im: IntendedMeans) -> None:
    """Goal states when finished plan `im` leaves the top of `it`: its goal is achieved;
    a `-!g` plan done ends the goal that failed (and those above it)."""
    if im.op == ADD_ACH:
        emit(rt, im.lit, GoalState.ACHIEVED)
        emit(rt, im.lit, GoalState.FINISHED)
    elif im.fail_target is not None:
        emit_stack(rt, it, (GoalState.FINISHED,), im.fail_target)
