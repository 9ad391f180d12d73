"""ActionsTable: the live actions, newest first; c / s / r cancel, suspend, resume the selected.

An action addressed to a role (a task: `models/tasks.py`) shows its holder and why that
robot won, or, while no robot can take it, `waiting`, the role in the robot column and
what it waits for in the reason.

Those three keys are debug keys: they go to the RCL directly (`action.control`), around
the agent, which learns of it only as its action's end. The operator's way is the
mission panel (goals, through the agent); a debug key says so in its question and in
the action's history."""

from __future__ import annotations

import time
from typing import ClassVar

from rich.text import Text
from textual.binding import Binding, BindingType

from mrss.messages import AllocationState
from mrss.tui import operator
from mrss.tui.events import Note, SendRequested
from mrss.tui.models.actions import ActionsModel, ActionView
from mrss.tui.models.robots import RobotsModel
from mrss.tui.widgets.border_text import set_border_subtitle
from mrss.tui.widgets.keyed_table import KeyedTable, Row, age_text, cell

STATE_STYLES = {
    "requested": "dim", "pending": "yellow", "running": "bold green", "suspended": "magenta",
    "succeeded": "green", "failed": "bold red", "cancelled": "red", "waiting": "yellow",
}


class ActionsTable(KeyedTable):
    """uuid (short), name, robot, goal, state, reason, progress of every known action."""

    COLUMNS = (("uuid", "uuid"), ("name", "name"), ("robot", "robot"), ("goal", "goal"),
               ("state", "state"), ("reason", "reason"), ("progress", "progress"),
               ("age", "age"))
    BINDINGS: ClassVar[list[BindingType]] = [
        Binding("c", "control('cancel')", "Debug cancel"),
        Binding("s", "control('suspend')", "Debug suspend"),
        Binding("r", "control('resume')", "Debug resume"),
    ]

    def __init__(self, model: ActionsModel, *, robots: RobotsModel | None = None,
                 id: str | None = None) -> None:
        super().__init__(id=id)
        self.model = model
        self.robots = robots or RobotsModel()  # an unavailable robot's reason
        self._cells: dict[str, tuple[tuple[str, ...], tuple[Text, ...]]] = {}

    MAX_ROWS = 200  # the newest; drawing more costs the operator responsiveness

    def refresh_rows(self, now: float | None = None) -> None:
        now = time.time() if now is None else now
        views = self.model.newest_first()
        shown = views[: self.MAX_ROWS]
        self.show([self._row(view, now) for view in shown])
        if len(self._cells) > 2 * self.MAX_ROWS:  # forget the rows no longer drawn
            keep = {view.uuid for view in shown}
            self._cells = {k: v for k, v in self._cells.items() if k in keep}
        set_border_subtitle(self, f"newest {self.MAX_ROWS} of {len(views)}"
                            if len(views) > self.MAX_ROWS else "")

    def _row(self, view: ActionView, now: float) -> Row:
        """The row's cells; rebuilt only when what they show changed (making `Text`
        cells is most of a redraw at 1,000 msgs/s: `mrss bench tui`)."""
        age = view.age(now)
        waits = view.waiting_for()
        reason = f"waits for {waits}" if waits else view.reason
        robot, state = view.robot, view.shown_state
        task = self.model.tasks.tasks.get(view.uuid)
        if task is not None and not view.terminal and not waits:
            if task.state is AllocationState.WAITING:
                robot, state, reason = task.role, "waiting", task.why(self._unavailable)
            else:  # its holder; why it won, unless its status says more (reassigning ...)
                robot, reason = task.robot, view.reason or task.why(self._unavailable)
        shown = (view.name or "?", robot, view.goal, state, reason,
                 view.progress_text(), "" if age is None else age_text(age))
        cached = self._cells.get(view.uuid)
        if cached is not None and cached[0] == shown:
            return view.uuid, cached[1]
        if cached is not None:  # most often the age alone: the other cells are kept
            before, old = cached
            cells = (old[0], *(old[i + 1] if before[i] == value else
                               cell(value, _style(i, value)) for i, value in enumerate(shown)))
        else:
            cells = (cell(view.uuid[:8], "dim"),
                     *(cell(value, _style(i, value)) for i, value in enumerate(shown)))
        self._cells[view.uuid] = (shown, cells)
        return view.uuid, cells

    def _unavailable(self, robot: str) -> str:
        known = self.robots.robots.get(robot)
        return known.reason if known is not None else ""

    def action_control(self, command: str) -> None:
        uuid = self.selected_key
        if uuid is None:
            self.post_message(Note("no action selected", error=True))
            return
        view = self.model.actions.get(uuid)
        if view is not None and view.terminal:
            self.post_message(Note(f"action {uuid[:8]} is already {view.state}", error=True))
            return
        name = view.name if view is not None and view.name else "?"
        what = f"debug {command} action {uuid[:8]} ({name})"
        confirm, details = "", []
        if command == "cancel":
            robot = view.robot if view is not None and view.robot else "?"
            goal = view.goal if view is not None and view.goal else "?"
            confirm = f"Cancel action {uuid[:8]} ({name} on {robot}, goal {goal})?"
            details = [f"{robot} stops this action; it ends cancelled and cannot be resumed.",
                       "Debug key: this goes to the RCL around the agent, which sees its "
                       "action cancelled; to end a goal, cancel it on the mission panel."]
        note = f"debug key {command}: sent to the RCL around the agent"
        self.post_message(SendRequested(operator.action_control(command, uuid), what,
                                        confirm=confirm, details=details,
                                        history=(uuid, note)))


#: each shown value's cell style, by its place in the row (after the uuid); the state's
#: by the state
_STYLES = ("bold", "", "", None, "italic", "", "dim")


def _style(index: int, value: str) -> str:
    style = _STYLES[index]
    return STATE_STYLES.get(value, "") if style is None else style
