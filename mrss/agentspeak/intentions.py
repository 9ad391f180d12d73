"""Intentions, their stacks of intended means, and events."""

from __future__ import annotations

from enum import StrEnum
from typing import TYPE_CHECKING, Any

from mrss.agentspeak.terms import Struct, Term

if TYPE_CHECKING:
    from mrss.agentspeak.formulas import Query
    from mrss.agentspeak.plans import Plan



class IntentionState(StrEnum):
    """Where an intention is (`.suspend` is orthogonal: a flag, as in Jason)."""

    RUNNABLE = "running"
    PENDING_EVENT = "pending_event"   # a sub-goal or belief event it posted awaits a plan
    WAIT_ACTION = "waiting_action"    # an environment action is executing at the host
    WAITING = "waiting"               # a .wait (time, event or condition)
    FINISHED = "finished"
    DROPPED = "dropped"


RUNNABLE = IntentionState.RUNNABLE
PENDING_EVENT = IntentionState.PENDING_EVENT
WAIT_ACTION = IntentionState.WAIT_ACTION
WAITING = IntentionState.WAITING
FINISHED = IntentionState.FINISHED
DROPPED = IntentionState.DROPPED


class IntendedMeans:
    """A plan instance on an intention's stack: the plan, its frame and where it is."""

    __slots__ = ("plan", "frame", "pc", "code", "lit", "op", "fail_target", "loops")

    def __init__(self, plan: Plan, frame: list[Any], lit: Struct, op: int) -> None:
        self.plan = plan
        self.frame = frame
        self.pc = 0
        self.code = plan.code
        self.lit = lit              # the event literal that selected the plan
        self.op = op                # the trigger operator (ADD_ACH, ...)
        self.fail_target: int | None = None  # for a -!g plan: stack depth to unwind to
        self.loops: list[Any] | None = None


class WaitInfo:
    """What a `.wait` waits for: a deadline, an event trigger, or a condition."""

    __slots__ = ("token", "trigger", "query", "frame", "deadline", "elapsed", "started",
                 "fail_on_timeout", "text", "what")

    def __init__(self, token: int, text: str) -> None:
        self.token = token
        self.trigger: Any = None
        self.query: Query | None = None
        self.frame: list[Any] | None = None
        self.deadline: float | None = None
        self.elapsed: Term | None = None
        self.started = 0.0
        self.fail_on_timeout = False
        self.text = text
        self.what: Term = text  # what it waits for, for the goal state `waiting`


class Intention:
    """A stack of intended means run one body formula per turn, round-robin."""

    __slots__ = ("id", "stack", "state", "suspended", "dropped", "in_queue", "wait",
                 "action", "action_lit", "line", "gen")

    def __init__(self, ident: int) -> None:
        self.id = ident
        self.stack: list[IntendedMeans] = []
        self.state: IntentionState = RUNNABLE
        self.suspended = False
        self.dropped = False
        self.in_queue = False
        self.wait: WaitInfo | None = None
        self.action: Any = None  # host handle of the running environment action
        self.action_lit: Any = None  # the action literal as sent (free variables kept)
        self.line = 0            # source line of the formula it is blocked on
        self.gen = 0             # bumped by stack surgery; stale events are ignored

    def __repr__(self) -> str:
        return f"Intention({self.id}, {self.state}, depth={len(self.stack)})"


class Event:
    """A triggering event: operator, literal, and the intention that posted it (or None
    for an external event, which starts a new intention)."""

    __slots__ = ("op", "lit", "intention", "tail", "target", "error", "gen")

    def __init__(self, op: int, lit: Struct, intention: Intention | None,
                 tail: bool = False) -> None:
        self.op = op
        self.lit = lit
        self.intention = intention
        self.tail = tail             # a `!g` that was the last formula of its plan (TRO)
        self.target = -1             # for -!g events: the stack depth to unwind to
        self.error: Any = None       # for -!g events: the failure (to cascade it)
        self.gen = intention.gen if intention is not None else 0
