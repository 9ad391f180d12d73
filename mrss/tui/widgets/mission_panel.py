"""MissionPanel: the mission's goals (state, robot, priority, its action) and the
operator's goal commands, which go to the agent as the project's events.

n opens a new command: the project's declared commands (`[operator.commands]`, each
its own form: `mrss.tui.command_form`) and the area form; c cancels the selected goal
(after a question), + / - raise or lower its priority by one. Each key becomes a
`MissionRequested` (the app sends it with `mrss.tui.mission`); a command the project
does not declare is refused with the reason.
"""

from __future__ import annotations

import logging
import time
from typing import ClassVar

from rich.text import Text
from textual.binding import Binding, BindingType

from mrss.config.operator import (
    GoalState,
    OperatorCommand,
    PayloadError,
    cancel_payload,
    priority_payload,
)
from mrss.tui.events import MissionRequested, Note
from mrss.tui.models.actions import ActionsModel
from mrss.tui.models.goals import GoalsModel, GoalView
from mrss.tui.models.logfilter import LogEntry
from mrss.tui.widgets.keyed_table import KeyedTable, Row, age_text, cell

STATE_STYLES = {
    GoalState.QUEUED: "yellow", GoalState.RUNNING: "bold green",
    GoalState.SUSPENDED: "magenta", GoalState.FAILED: "bold red", GoalState.DONE: "green",
    GoalState.CANCELLED: "red", GoalState.REFUSED: "bold red",
}


class MissionPanel(KeyedTable):
    """One row per goal: open goals first, newest first."""

    COLUMNS = (("goal", "goal"), ("state", "state"), ("robot", "robot"),
               ("priority", "prio"), ("why", "why"), ("since", "since"))
    BINDINGS: ClassVar[list[BindingType]] = [
        Binding("n", "new_area", "New command"),
        Binding("c", "cancel_goal", "Cancel goal"),
        Binding("plus,equals_sign", "priority(1)", "Priority +1"),
        Binding("minus", "priority(-1)", "Priority -1"),
    ]

    def __init__(self, goals: GoalsModel, actions: ActionsModel, *,
                 id: str | None = None) -> None:
        super().__init__(id=id)
        self.goals = goals
        self.actions = actions

    def refresh_rows(self, now: float | None = None) -> None:
        now = time.time() if now is None else now
        self.show([self._row(view, now) for view in self.goals.newest_first()])

    def _row(self, view: GoalView, now: float) -> Row:
        why = self.goals.reason(view, self.actions)
        last = self.goals.last_action(view.goal, self.actions)
        if view.state is GoalState.RUNNING and last is not None and last.progress \
                and not last.terminal and not last.waiting_for():
            why += " " + last.progress_text(24)
        prio = "" if view.priority is None else str(view.priority)
        bad = view.state in (GoalState.FAILED, GoalState.REFUSED)
        return view.goal, (
            cell(view.goal, "bold"), cell(view.state.value, STATE_STYLES[view.state]),
            cell(view.robot), cell(prio), cell(why, "red" if bad else "italic"),
            cell(age_text(max(0.0, now - view.since)) if view.since else "", "dim"))

    def selected_goal(self) -> GoalView | None:
        key = self.selected_key
        return self.goals.goals.get(key) if key is not None else None

    def action_new_area(self) -> None:
        opener = getattr(getattr(self.app, "steering", None), "open_command_menu", None)
        if callable(opener):
            opener()

    def action_cancel_goal(self) -> None:
        view = self.selected_goal()
        if view is None:
            self.post_message(Note("no goal selected", error=True))
            return
        if view.state.ended:
            self.post_message(Note(f"goal {view.goal} is already {view.state.value}",
                                   error=True))
            return
        robot = view.robot or "?"
        self.post_message(MissionRequested(
            OperatorCommand.CANCEL, cancel_payload(view.goal), f"cancel goal {view.goal}",
            confirm=f"Cancel goal {view.goal} ({view.state.value} on {robot})?",
            details=[f"The agent is told the operator cancelled {view.goal}: its own plan "
                     "stops the goal's action and forgets the goal."]))

    def action_priority(self, step: int) -> None:
        view = self.selected_goal()
        if view is None:
            self.post_message(Note("no goal selected", error=True))
            return
        if view.state.ended or view.priority is None:
            why = f"is {view.state.value}" if view.state.ended else "has no known priority"
            self.post_message(Note(f"goal {view.goal} {why}", error=True))
            return
        new = view.priority + step
        try:
            payload = priority_payload(view.goal, str(new))
        except PayloadError as exc:
            self.post_message(Note(str(exc), error=True))
            return
        self.post_message(MissionRequested(
            OperatorCommand.PRIORITY, payload,
            f"priority of {view.goal} {view.priority} -> {new}"))


def goal_line(view: GoalView, why: str = "") -> LogEntry:
    """The log pane's line for a goal that ended: `goal a1 failed (uav1): link lost`."""
    stamp = time.strftime("%H:%M:%S", time.localtime(view.since))
    robot = f" ({view.robot})" if view.robot else ""
    bad = view.state in (GoalState.FAILED, GoalState.REFUSED)
    level = logging.WARNING if bad else logging.INFO
    return LogEntry(Text.assemble((f"{stamp} ", "dim"), ("goal ", "bold"), view.goal, " ",
                                  (view.state.value, STATE_STYLES[view.state]), robot,
                                  f": {why}" if why else ""),
                    level, "mission")
