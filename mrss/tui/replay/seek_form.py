"""SeekScreen: the replay's `T`: type a time to seek to.

Accepted: a time since the recording's start (`90`, `1:30`, `1:02:03`), a step from the
cursor (`+30`, `-1:00`), or a time of day (`@14:05:10`, the recording's first day).
Enter seeks; a text that is none of these says what was expected and stays open; Esc
closes without moving. The result is the recorded time (Unix s), or None.
"""

from __future__ import annotations

import time
from typing import ClassVar

from textual.app import ComposeResult
from textual.binding import Binding, BindingType
from textual.containers import Vertical
from textual.screen import ModalScreen
from textual.widgets import Input, Static

EXPECTED = "expected seconds or m:ss or h:mm:ss since the start, +/- a step, or @hh:mm:ss"


def seconds_of(text: str) -> float:
    """`s`, `m:ss` or `h:mm:ss` as seconds; ValueError if it is none of them."""
    parts = text.split(":")
    if not 1 <= len(parts) <= 3 or any(not p.strip() for p in parts):
        raise ValueError(EXPECTED)
    total = 0.0
    for part in parts:
        value = float(part)
        if value < 0 or value != value:  # negative or NaN
            raise ValueError(EXPECTED)
        total = total * 60 + value
    return total


def seek_target(text: str, *, start: float, cursor: float) -> float:
    """The recorded time `text` names (module doc); ValueError saying what was expected."""
    text = text.strip()
    try:
        if text.startswith(("+", "-")):
            step = seconds_of(text[1:])
            return cursor + (step if text[0] == "+" else -step)
        if text.startswith("@"):
            day = time.localtime(start)
            midnight = time.mktime((day.tm_year, day.tm_mon, day.tm_mday, 0, 0, 0, 0, 0, -1))
            return midnight + seconds_of(text[1:])
        return start + seconds_of(text)
    except ValueError:
        raise ValueError(f"{text!r}: {EXPECTED}") from None


class SeekScreen(ModalScreen[float | None]):
    """Ask for a time; the recorded time chosen, or None."""

    DEFAULT_CSS = """
    SeekScreen { align: center middle; }
    SeekScreen > Vertical { width: 70; height: auto; border: thick $accent;
                            background: $surface; padding: 1 2; }
    SeekScreen #seek-error { color: $error; }
    """
    BINDINGS: ClassVar[list[BindingType]] = [Binding("escape", "close", "Close")]

    def __init__(self, *, start: float, cursor: float) -> None:
        super().__init__()
        self.start = start
        self.cursor = cursor

    def compose(self) -> ComposeResult:
        with Vertical():
            yield Static("Seek to: 1:30 from the start, +30 / -10 from here, @14:05:10")
            yield Input(placeholder="time", id="seek-time")
            yield Static("", id="seek-error")

    def on_input_submitted(self, event: Input.Submitted) -> None:
        event.stop()
        try:
            target = seek_target(event.value, start=self.start, cursor=self.cursor)
        except ValueError as exc:
            self.query_one("#seek-error", Static).update(str(exc))
            return
        self.dismiss(target)

    def action_close(self) -> None:
        self.dismiss(None)
