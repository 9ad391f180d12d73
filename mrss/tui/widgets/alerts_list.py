"""AlertsScreen (`!`): every alert kept, newest first; acknowledge them one by one.

A row per alert: new or acknowledged, over or still on, what, about whom, how often,
when, the latest detail. Enter (or space) acknowledges the alert under the cursor; `A`
acknowledges them all, as on the main screen. The list redraws every second (alerts
raised meanwhile appear); Esc or q closes it.
"""

from __future__ import annotations

import time
from collections.abc import Callable
from typing import ClassVar

from rich.text import Text
from textual.app import ComposeResult
from textual.binding import Binding, BindingType
from textual.containers import Vertical
from textual.coordinate import Coordinate
from textual.screen import ModalScreen
from textual.widgets import DataTable, Static

from mrss.tui.models.alerts import Alert, AlertsModel

COLUMNS = ("state", "alert", "subject", "times", "last", "detail")


def _key(alert: Alert) -> str:
    return f"{alert.label}\x1f{alert.subject}"


class AlertsScreen(ModalScreen[None]):
    """The alerts' history as a table; the app's strip is redrawn on each change."""

    DEFAULT_CSS = """
    AlertsScreen { align: center middle; }
    AlertsScreen > Vertical { width: 95%; height: 85%; border: thick $accent;
                              background: $surface; }
    AlertsScreen #alerts-status { height: 1; padding: 0 1; }
    """
    BINDINGS: ClassVar[list[BindingType]] = [
        Binding("enter,space", "ack_one", "Acknowledge this alert"),
        Binding("A", "ack_all", "Acknowledge all"),
        Binding("escape,q,exclamation_mark", "close", "Close"),
    ]

    def __init__(self, model: AlertsModel, changed: Callable[[str], None]) -> None:
        super().__init__()
        self.model = model
        self.changed = changed  # called with what was done (the app redraws its strip)
        self._keys: dict[str, tuple[str, str]] = {}

    def compose(self) -> ComposeResult:
        with Vertical():
            yield Static(Text("Alerts, newest first (Enter: acknowledge this one, A: all, "
                              "Esc: close)", style="bold"))
            table: DataTable[Text] = DataTable(id="alerts-table", cursor_type="row")
            yield table
            yield Static("", id="alerts-status")

    def on_mount(self) -> None:
        table: DataTable[Text] = self.query_one(DataTable)
        for column in COLUMNS:
            table.add_column(column, key=column)
        self.redraw()
        self.set_interval(1.0, self.redraw)
        table.focus()

    def redraw(self) -> None:
        table: DataTable[Text] = self.query_one(DataTable)
        history = self.model.history()
        keys = [_key(alert) for alert in history]
        if keys != list(self._keys):
            cursor = table.cursor_row
            table.clear()
            self._keys = {}
            for key, alert in zip(keys, history, strict=True):
                self._keys[key] = alert.key
                table.add_row(*self._cells(alert), key=key)
            if history:
                table.move_cursor(row=min(max(cursor, 0), len(history) - 1))
        else:
            for key, alert in zip(keys, history, strict=True):
                for column, cell in zip(COLUMNS, self._cells(alert), strict=True):
                    table.update_cell(key, column, cell)
        new = len(self.model.unacked())
        self.query_one("#alerts-status", Static).update(
            Text(f"{len(history)} alerts, {new} new" if history else "no alerts yet", "dim"))

    @staticmethod
    def _cells(alert: Alert) -> list[Text]:
        style = "" if alert.acked else ("bold red" if alert.severe else "bold yellow")
        state = ("acked" if alert.acked else "NEW") + (", over" if alert.resolved else "")
        stamp = time.strftime("%H:%M:%S", time.localtime(alert.ts))
        return [Text(state, style), Text(alert.label, style), Text(alert.subject),
                Text(str(alert.count)), Text(stamp), Text(alert.text)]

    def selected(self) -> Alert | None:
        table: DataTable[Text] = self.query_one(DataTable)
        if not self._keys or table.cursor_row < 0:
            return None
        row_key = table.coordinate_to_cell_key(Coordinate(table.cursor_row, 0)).row_key.value
        key = self._keys.get(row_key or "")
        return self.model.alerts.get(key) if key is not None else None

    def action_ack_one(self) -> None:
        alert = self.selected()
        if alert is None:
            return
        if self.model.acknowledge_one(alert.key):
            self.changed(f"acknowledged {alert.line()}")
        self.redraw()

    def on_data_table_row_selected(self, event: DataTable.RowSelected) -> None:
        event.stop()  # Enter on the table: its own "select" binding comes first
        self.action_ack_one()

    def action_ack_all(self) -> None:
        count = self.model.acknowledge()
        self.changed(f"acknowledged {count} alert{'s' if count != 1 else ''}")
        self.redraw()

    def action_close(self) -> None:
        self.dismiss(None)
