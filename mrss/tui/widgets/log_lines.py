"""LogLinesScreen (`L`): pick one log line and read it whole.

The log pane cuts long lines at its width. This screen lists the pane's recent lines
(those its filter shows, newest last, the cursor on the newest); the line under the
cursor is shown below in full, wrapped, with its time, level and component (Enter
shows it too); Esc, q or L closes. The list is the one the pane had when the screen
opened.
"""

from __future__ import annotations

import logging
from typing import ClassVar

from rich.text import Text
from textual.app import ComposeResult
from textual.binding import Binding, BindingType
from textual.containers import Vertical, VerticalScroll
from textual.screen import ModalScreen
from textual.widgets import OptionList, Static
from textual.widgets.option_list import Option

from mrss.tui.models.logfilter import LogEntry

SHOWN = 1000  # the newest lines listed


def line_detail(entry: LogEntry) -> Text:
    """The whole line and what the dashboard knows of it."""
    stamp, _, rest = entry.plain.partition(" ")
    text = Text()
    for key, value in (("time", stamp), ("level", logging.getLevelName(entry.level)),
                       ("component", entry.component or "-")):
        text.append(f"{key:<10}", "dim")
        text.append(f"{value}\n")
    text.append("\n")
    text.append(rest)
    return text


class LogLinesScreen(ModalScreen[None]):
    """The recent lines with a cursor; the chosen one in full below."""

    DEFAULT_CSS = """
    LogLinesScreen { align: center middle; }
    LogLinesScreen > Vertical { width: 95%; height: 90%; border: thick $accent;
                                background: $surface; }
    LogLinesScreen OptionList { height: 2fr; }
    LogLinesScreen #line-box { height: 1fr; border-top: solid $primary-darken-2;
                               padding: 0 1; }
    """
    BINDINGS: ClassVar[list[BindingType]] = [
        Binding("escape,q,L", "close", "Close"),
    ]

    def __init__(self, entries: list[LogEntry]) -> None:
        super().__init__()
        self.entries = entries[-SHOWN:]
        self.shown = ""  # the plain text of the line shown in full (tests, captures)

    def compose(self) -> ComposeResult:
        with Vertical():
            yield Static(Text(f"Log lines ({len(self.entries)}; arrows pick, Enter shows "
                              "one in full, Esc closes)", style="bold"))
            yield OptionList(*[Option(Text(e.plain, no_wrap=True, overflow="ellipsis"))
                               for e in self.entries], id="log-lines-list")
            with VerticalScroll(id="line-box"):
                yield Static("", id="line-full")

    def on_mount(self) -> None:
        options = self.query_one(OptionList)
        if self.entries:
            options.highlighted = len(self.entries) - 1
        else:
            self.query_one("#line-full", Static).update(Text("the log has no lines yet", "dim"))
        options.focus()

    def show(self, index: int | None) -> None:
        if index is None or not 0 <= index < len(self.entries):
            return
        detail = line_detail(self.entries[index])
        self.shown = detail.plain
        self.query_one("#line-full", Static).update(detail)

    def on_option_list_option_highlighted(self, event: OptionList.OptionHighlighted) -> None:
        event.stop()
        self.show(event.option_index)

    def on_option_list_option_selected(self, event: OptionList.OptionSelected) -> None:
        event.stop()
        self.show(event.option_index)

    def action_close(self) -> None:
        self.dismiss(None)
