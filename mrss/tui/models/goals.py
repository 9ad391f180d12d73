"""The mission's goals as the dashboard knows them: read from the agent's beliefs.

The project names its goal beliefs in `[operator.goals]` (`task(Robot, Goal, Priority)`
is running, ...; `mrss.config.operator`). Each mind snapshot is matched against those
patterns: a goal found is queued, running, suspended or failed, with its robot and
priority. A pattern with no `Robot` (a goal the agent asks of a role, `task(_, Goal,
Priority)`: the RCL picks the robot) takes the robot from the goal's newest action while
it is open, and a running goal whose newest action is suspended in the RCL shows as
suspended. Projects that declare `done` and `cancelled` patterns say how a goal ended;
otherwise a goal that was seen and is no longer in any pattern has ended, and how is
inferred: cancelled if the operator cancelled it from here, failed if its last action
failed, else done.
Nothing here knows Textual.
"""

from __future__ import annotations

import itertools
from collections.abc import Iterable
from dataclasses import dataclass

from mrss.agentspeak import AslSyntaxError, parse_literal
from mrss.agentspeak.terms import Struct, term_str
from mrss.config.operator import GoalPattern, GoalState
from mrss.tui.models.actions import ActionsModel, ActionView

# a goal seen in several patterns at once is in the first of these (an open state
# first: a goal sent again after it ended is open again)
PRECEDENCE = (GoalState.RUNNING, GoalState.SUSPENDED, GoalState.QUEUED, GoalState.REFUSED,
              GoalState.FAILED, GoalState.CANCELLED, GoalState.DONE)
ENDED_KEEP = 100  # ended goals remembered


@dataclass
class GoalView:
    """One goal: where it stands, for which robot, at which priority."""

    goal: str
    seq: int
    state: GoalState = GoalState.QUEUED
    robot: str = ""
    priority: int | None = None
    since: float = 0.0  # when it entered its state (a snapshot's time)
    why: str = ""  # the reason the agent gives (a pattern's `Why`), if it gives one


class GoalsModel:
    """Goals by name, newest first; `apply_beliefs` per mind snapshot."""

    def __init__(self, patterns: dict[GoalState, GoalPattern] | None = None) -> None:
        self.patterns = dict(patterns or {})
        self.goals: dict[str, GoalView] = {}
        self.cancelled_here: set[str] = set()  # the operator cancelled these from here
        self._seq = itertools.count()
        self._prefixes = tuple(f"{p.functor}(" for p in self.patterns.values())
        self._ended: list[GoalView] = []  # goals that ended since `take_ended`

    @property
    def declared(self) -> bool:
        return bool(self.patterns)

    def apply_beliefs(self, beliefs: Iterable[str], when: float,
                      actions: ActionsModel | None = None) -> bool:
        """Update from a snapshot's beliefs; whether anything changed."""
        found: dict[str, tuple[GoalState, dict[str, object]]] = {}
        for text in beliefs:
            if not text.startswith(self._prefixes):
                continue
            literal = _literal(text)
            if literal is None:
                continue
            for state, pattern in self.patterns.items():
                named = pattern.match(literal)
                if named is None:
                    continue
                goal = _text(named["Goal"])
                old = found.get(goal)
                if old is None or PRECEDENCE.index(state) < PRECEDENCE.index(old[0]):
                    found[goal] = (state, named)
        changed = False
        for goal, (state, named) in found.items():
            view = self.goals.get(goal)
            if view is None:
                view = self.goals[goal] = GoalView(goal, next(self._seq), state, since=when)
                changed = True
            # an open goal with no Robot in its pattern: its newest action's robot (an
            # ended one keeps the robot it was last seen on)
            last = None if "Robot" in named or state.ended else \
                self.last_action(goal, actions)
            robot = _text(named["Robot"]) if "Robot" in named else \
                (last.robot if last is not None and last.robot else view.robot)
            if state is GoalState.RUNNING and last is not None and last.state == "suspended":
                state = GoalState.SUSPENDED  # a task addressed to a role, held in the RCL
            priority = named.get("Priority")
            prio = priority if isinstance(priority, int) else view.priority
            if "Why" in named and _text(named["Why"]) != view.why:
                view.why = _text(named["Why"])
                changed = True
            if (view.state, view.robot, view.priority) != (state, robot, prio):
                if view.state != state:
                    view.since = when
                    if state.ended:
                        self._ended.append(view)
                view.state, view.robot, view.priority = state, robot, prio
                changed = True
        for view in self.goals.values():
            if view.goal in found or view.state.ended:
                continue  # said by the agent, or already ended
            view.state = self._ending(view.goal, actions)
            view.since = when
            self._ended.append(view)
            changed = True
        self._forget_ended()
        return changed

    def _ending(self, goal: str, actions: ActionsModel | None) -> GoalState:
        if goal in self.cancelled_here:
            return GoalState.CANCELLED
        last = self.last_action(goal, actions)
        if last is not None and last.state == "failed":
            return GoalState.FAILED
        if last is not None and last.state == "cancelled":
            return GoalState.CANCELLED
        return GoalState.DONE

    @staticmethod
    def last_action(goal: str, actions: ActionsModel | None) -> ActionView | None:
        if actions is None:
            return None
        mine = [v for v in actions.actions.values() if v.goal == goal]
        return max(mine, key=lambda v: v.seq) if mine else None

    def reason(self, view: GoalView, actions: ActionsModel | None) -> str:
        """Why the goal stands where it does, for the operator.

        Queued: for which robot, behind which goal; running: its action (queued for a
        resource, behind which action, when it waits for one); failed, cancelled or
        refused: the reason the agent gives, else its last action's reason and cause."""
        last = self.last_action(view.goal, actions)
        if view.state is GoalState.QUEUED:
            ahead = self.current_goal(view.robot) if view.robot else None
            where = f"for {view.robot}" if view.robot else "for a robot"
            return where + (f" behind {ahead.goal}" if ahead is not None else "")
        if view.state.ended or view.state is GoalState.SUSPENDED:
            if view.why:
                return view.why
            if last is not None and view.state is not GoalState.DONE and last.reason:
                cause = last.cause
                return last.reason + (f" ({cause})" if cause and cause not in last.reason
                                      else "")
            return ""
        if last is None:
            return ""
        waiting = last.waiting_for()
        if waiting:
            behind = ", ".join(self._names(last.behind(), actions))
            return f"{last.name} queued for {waiting}" + (f" behind {behind}" if behind else "")
        return f"{last.name} {last.shown_state}"

    @staticmethod
    def _names(uuids: list[str], actions: ActionsModel | None) -> list[str]:
        known = actions.actions if actions is not None else {}
        return [known[u].goal or known[u].name if u in known else u[:8] for u in uuids]

    def take_ended(self) -> list[GoalView]:
        """The goals that ended since the last call, in the order they ended."""
        ended, self._ended = self._ended, []
        return ended

    def _forget_ended(self) -> None:
        ended = [v for v in self.goals.values() if v.state.ended]
        for view in sorted(ended, key=lambda v: v.seq)[: max(0, len(ended) - ENDED_KEEP)]:
            del self.goals[view.goal]

    def newest_first(self) -> list[GoalView]:
        """Open goals first (newest first), then ended ones (newest first)."""
        return sorted(self.goals.values(), key=lambda v: (v.state.ended, -v.seq))

    def current_goal(self, robot: str) -> GoalView | None:
        """The goal `robot` works on now (running), else its suspended one."""
        for state in (GoalState.RUNNING, GoalState.SUSPENDED):
            for view in self.goals.values():
                if view.robot == robot and view.state is state:
                    return view
        return None


def _literal(text: str) -> Struct | None:
    try:
        return parse_literal(text)
    except (AslSyntaxError, AssertionError, ValueError, RecursionError):
        return None


def _text(term: object) -> str:
    if isinstance(term, Struct) and not term.args:
        return term.functor
    return term_str(term)  # type: ignore[arg-type]
