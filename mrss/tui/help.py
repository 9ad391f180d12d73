"""HelpScreen (`?`, F1): every key that works right now, made from the bindings themselves.

The list is read from `Screen.active_bindings` when help is asked for: the app's keys,
the screen's, and those of the focused panel and its containers, with each binding's
description. So it names exactly what a key press would do, hidden keys included, and
cannot drift from the code.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

from rich.table import Table
from rich.text import Text
from textual import events
from textual.app import App, ComposeResult
from textual.containers import VerticalScroll
from textual.screen import ModalScreen
from textual.widgets import Static


@dataclass(frozen=True)
class KeyHelp:
    """One key: where it works (`anywhere` or the panel's name), the key, what it does;
    `own`: one of the footer's (the panel's own commands, not moving about)."""

    where: str
    key: str
    does: str
    own: bool = True


def current_keys(app: App[Any]) -> list[KeyHelp]:
    """The keys active on the app's screen now: the focused panel's first, each place's
    own commands before its moving keys (cursor, scrolling)."""
    rows: list[KeyHelp] = []
    for key, active in app.screen.active_bindings.items():
        binding, node = active.binding, active.node
        if node is app or node is app.screen:
            where = "anywhere"
        else:
            where = getattr(node, "id", None) or type(node).__name__
        shown = app.get_key_display(binding) if key == binding.key else key
        rows.append(KeyHelp(where, shown, binding.description or binding.action,
                            binding.show))
    return sorted(rows, key=lambda r: (r.where == "anywhere", r.where, not r.own, r.key))


class HelpScreen(ModalScreen[None]):
    """The keys, in a table; any key closes it."""

    DEFAULT_CSS = """
    HelpScreen { align: center middle; }
    HelpScreen > VerticalScroll {
        width: 90; height: auto; max-height: 90%;
        border: thick $accent; background: $surface; padding: 0 1;
    }
    """

    def __init__(self, keys: list[KeyHelp], focused: str) -> None:
        super().__init__()
        self.keys = keys
        self.focus_name = focused

    def compose(self) -> ComposeResult:
        table = Table(title=f"Keys (focused: {self.focus_name}; Ctrl+P: commands)",
                      expand=True, show_edge=False)
        for column in ("where", "key", "does"):
            table.add_column(column)
        for row in self.keys:
            table.add_row(Text(row.where), Text(row.key, "bold"), Text(row.does))
        with VerticalScroll():
            yield Static(table, id="keys")
            yield Static(Text("any key closes this", "dim"))

    def on_key(self, event: events.Key) -> None:
        event.stop()
        event.prevent_default()
        self.dismiss(None)
