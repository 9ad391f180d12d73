"""LogPane: log records, supervision events, operator commands and the TUI's notes, a line each.

Periodic traffic (heartbeats, tree, mind and snapshot requests and answers) is not shown.
The last `MAX_LINES` lines are kept; `lines_text()` returns them as plain text.

- Follow / pause: the pane follows new lines until the operator scrolls up (keys or
  wheel); then it stays put and its subtitle counts the lines that arrived meanwhile.
  `End` (or `f`) goes to the bottom and follows again.
- Filter: `/` opens the filter line above the log (see `mrss.tui.models.logfilter`:
  `level:warn`, `comp:rcl` or `@rcl`, plain words); the pane redraws with the matching
  lines as the operator types. `Enter` or `Esc` go back to the log; an empty filter
  shows everything.
"""

from __future__ import annotations

import logging
import time
from collections import deque
from typing import Any, ClassVar

from rich.text import Text
from textual.app import ComposeResult
from textual.binding import Binding, BindingType
from textual.containers import Vertical
from textual.widgets import Input, RichLog

from mrss.messages import Command, Envelope, LogRecord, SupEvent
from mrss.tui.models.logfilter import LogEntry, LogFilter, LogFilterError, level_of
from mrss.tui.widgets.border_text import set_border_subtitle
from mrss.tui.widgets.steady_scroll import SteadyScroll

MAX_LINES = 2000
QUIET_COMMANDS = ("mind", "tree", "snapshot", "questions")  # the dashboard's own polling
LEVEL_STYLES = {"DEBUG": "dim", "INFO": "", "WARNING": "yellow", "ERROR": "bold red",
                "CRITICAL": "bold red"}
SUP_STYLES = {"start": "green", "restart": "yellow", "exit": "red", "hang": "bold red",
              "escalate": "bold red", "give_up": "bold red", "quarantine": "bold red",
              "release": "green"}
SUP_WARNINGS = ("exit", "hang", "escalate", "give_up", "quarantine")


def log_line(env: Envelope) -> LogEntry | None:
    """The line for one bus message, or None if the log does not show it."""
    body = env.body
    stamp = time.strftime("%H:%M:%S", time.localtime(env.ts))
    if isinstance(body, LogRecord):
        style = LEVEL_STYLES.get(body.level.upper(), "")
        return LogEntry(Text.assemble((f"{stamp} ", "dim"), (f"{body.level[:4]:<4} ", style),
                                      (f"{body.component}: ", "bold"), (body.message, style)),
                        level_of(body.level), body.component)
    if isinstance(body, SupEvent) and body.event not in ("tree", "heartbeat"):
        parts = [f"{body.supervisor}/{body.child}" if body.supervisor else body.child]
        if body.pid:
            parts.append(f"pid={body.pid}")
        if body.count:
            parts.append(f"count={body.count}")
        if body.reason:
            parts.append(f"reason={body.reason!r}")
        level = logging.WARNING if body.event in SUP_WARNINGS else logging.INFO
        return LogEntry(Text.assemble((f"{stamp} ", "dim"),
                                      (f"sup.{body.event} ", SUP_STYLES.get(body.event, "")),
                                      " ".join(parts)), level, parts[0])
    if isinstance(body, Command) and body.command not in QUIET_COMMANDS:
        args = " ".join(f"{k}={v}" for k, v in body.args.items())
        return LogEntry(Text.assemble((f"{stamp} ", "dim"), (f"ctl.{body.command} ", "cyan"),
                                      f"{body.target} {args} (from {env.src})"
                                      .replace("  ", " ")), logging.INFO, env.src)
    return None


class LogView(SteadyScroll, RichLog):
    """The scrolling lines; scrolling up pauses following, `End` resumes it."""

    BINDINGS: ClassVar[list[BindingType]] = [Binding("f", "scroll_end", "Follow log")]

    def __init__(self) -> None:
        super().__init__(id="log-lines", max_lines=MAX_LINES, wrap=False, markup=False)

    def _pause(self) -> None:
        pane = self.parent
        if isinstance(pane, LogPane):
            pane.set_following(False)

    def action_scroll_up(self) -> None:
        self._pause()
        super().action_scroll_up()

    def action_page_up(self) -> None:
        self._pause()
        super().action_page_up()

    def action_scroll_home(self) -> None:
        self._pause()
        super().action_scroll_home()

    def on_mouse_scroll_up(self, _: Any) -> None:  # besides RichLog's own scrolling
        self._pause()

    def action_scroll_end(self) -> None:
        pane = self.parent
        if isinstance(pane, LogPane):
            pane.set_following(True)
        super().action_scroll_end()


class LogPane(Vertical):
    """The log panel: a hidden filter line over the lines; `add` takes one batch."""

    DEFAULT_CSS = """
    LogPane #log-filter { display: none; height: 3; }
    LogPane.-filtering #log-filter { display: block; }
    """

    def __init__(self, *, id: str | None = None) -> None:
        super().__init__(id=id)
        self._entries: deque[LogEntry] = deque(maxlen=MAX_LINES)
        self.filter = LogFilter()
        self.following = True
        self.missed = 0  # lines that arrived while paused

    def compose(self) -> ComposeResult:
        yield Input(placeholder="filter: level:warn comp:rcl words (Enter/Esc: back)",
                    id="log-filter")
        yield LogView()

    @property
    def view(self) -> LogView:
        return self.query_one(LogView)

    def add(self, entries: list[LogEntry]) -> None:
        view = self.view
        for entry in entries[-MAX_LINES:]:
            self._entries.append(entry)
            if self.filter.matches(entry):
                view.write(entry.text, scroll_end=self.following)
                if not self.following:
                    self.missed += 1
        if not self.following:
            self._subtitle()

    def replace(self, entries: list[LogEntry], shown_most: int = MAX_LINES) -> None:
        """Keep `entries` instead of every line so far (a replay moved its cursor), and
        show the newest `shown_most` of them that pass the filter, in one write (a
        write a line costs a third of a millisecond each); `L` lists them all."""
        self._entries.clear()
        self._entries.extend(entries[-MAX_LINES:])
        view = self.view
        view.clear()
        self.missed = 0
        shown: list[Text] = []
        for entry in reversed(self._entries):  # the newest first, until enough
            if len(shown) >= shown_most:
                break
            if self.filter.matches(entry):
                shown.append(entry.text)
        shown.reverse()
        if shown:
            view.write(Text("\n").join(shown), scroll_end=self.following)
        if not self.following:
            self._subtitle()

    def note(self, text: str, *, error: bool = False) -> None:
        """A line from the TUI itself (what the operator did)."""
        stamp = time.strftime("%H:%M:%S")
        self.add([LogEntry(Text.assemble((f"{stamp} ", "dim"), ("tui ", "cyan"),
                                         (text, "bold red" if error else "")),
                           logging.ERROR if error else logging.INFO, "tui")])

    def lines_text(self) -> list[str]:
        """Every line kept, filtered or not."""
        return [entry.plain for entry in self._entries]

    def shown_text(self) -> list[str]:
        """The lines the filter lets through (what the pane shows)."""
        return [entry.plain for entry in self._entries if self.filter.matches(entry)]

    def shown_entries(self) -> list[LogEntry]:
        """The entries the filter lets through, oldest first (`L` lists them)."""
        return [entry for entry in self._entries if self.filter.matches(entry)]

    def set_following(self, on: bool) -> None:
        if on == self.following:
            return
        self.following = on
        self.missed = 0
        self.view.auto_scroll = on
        self._subtitle()

    def set_filter(self, text: str) -> str:
        """Show only the lines matching `text`; an error text (and no change) if it is bad."""
        try:
            new = LogFilter.parse(text)
        except LogFilterError as exc:
            set_border_subtitle(self, f"filter not applied: {exc}")
            return str(exc)
        self.filter = new
        view = self.view
        view.clear()
        for entry in self._entries:
            if new.matches(entry):
                view.write(entry.text, scroll_end=self.following)
        self._subtitle()
        return ""

    def open_filter(self) -> None:
        self.add_class("-filtering")
        self.query_one("#log-filter", Input).focus()

    def on_input_changed(self, event: Input.Changed) -> None:
        event.stop()
        self.set_filter(event.value)

    def on_input_submitted(self, event: Input.Submitted) -> None:
        event.stop()
        self.close_filter()

    def close_filter(self) -> None:
        if not self.filter.active:
            self.remove_class("-filtering")
        self.view.focus()

    def _subtitle(self) -> None:
        parts = []
        if self.filter.active:
            parts.append(f"filter: {self.filter.text}")
        if not self.following:
            parts.append(f"paused, {self.missed} new (End follows)")
        set_border_subtitle(self, " · ".join(parts))
