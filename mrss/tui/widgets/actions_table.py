"""ActionsTable: the live actions, newest first; c / s / r cancel, suspend, resume the selected."""

from __future__ import annotations

from typing import ClassVar

from textual.binding import Binding, BindingType

from mrss.tui import operator
from mrss.tui.events import Note, SendRequested
from mrss.tui.models.actions import ActionsModel, ActionView
from mrss.tui.widgets.keyed_table import KeyedTable, Row, cell

STATE_STYLES = {
    "requested": "dim", "pending": "yellow", "running": "bold green", "suspended": "magenta",
    "succeeded": "green", "failed": "bold red", "cancelled": "red",
}


class ActionsTable(KeyedTable):
    """uuid (short), name, robot, goal, state, reason, progress of every known action."""

    COLUMNS = (("uuid", "uuid"), ("name", "name"), ("robot", "robot"), ("goal", "goal"),
               ("state", "state"), ("reason", "reason"), ("progress", "progress"))
    BINDINGS: ClassVar[list[BindingType]] = [
        Binding("c", "control('cancel')", "Cancel"),
        Binding("s", "control('suspend')", "Suspend"),
        Binding("r", "control('resume')", "Resume"),
    ]

    def __init__(self, model: ActionsModel, *, id: str | None = None) -> None:
        super().__init__(id=id)
        self.model = model

    MAX_ROWS = 200  # the newest; drawing more costs the operator responsiveness

    def refresh_rows(self) -> None:
        views = self.model.newest_first()
        self.show([self._row(view) for view in views[: self.MAX_ROWS]])
        self.border_subtitle = (f"newest {self.MAX_ROWS} of {len(views)}"
                                if len(views) > self.MAX_ROWS else "")

    @staticmethod
    def _row(view: ActionView) -> Row:
        name = view.name or "?"
        return view.uuid, (
            cell(view.uuid[:8], "dim"), cell(name, "bold"), cell(view.robot),
            cell(view.goal), cell(view.state, STATE_STYLES.get(view.state, "")),
            cell(view.reason, "italic"), cell(view.progress_text()))

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
        self.post_message(SendRequested(operator.action_control(command, uuid),
                                        f"{command} action {uuid[:8]} ({name})"))
