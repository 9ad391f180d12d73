"""TimelineBar: where a replay is, on a bar of the whole recording with its events.

Two lines: the play state, speed, the cursor's time since the start and of day, the
keys; then the bar, one cell a slice of the recording: `✗` an action failed, `↻` a
component restarted, `!` an alert, the cursor `┃`. A click on the bar asks to seek
there (`TimelineBar.Seek`). The app redraws it as the cursor moves (`show`).
"""

from __future__ import annotations

import time
from itertools import groupby

from rich.text import Text
from textual import events
from textual.message import Message
from textual.widgets import Static

from mrss.tui.replay.index import Mark, MarkKind
from mrss.tui.replay.player import Player, PlayState

GLYPHS = {MarkKind.ACTION_FAILED: ("✗", "bold red"), MarkKind.RESTART: ("↻", "bold yellow"),
          MarkKind.ALERT: ("!", "bold magenta")}
STATE_GLYPHS = {PlayState.PLAYING: "▶", PlayState.PAUSED: "⏸", PlayState.ENDED: "⏹"}
KEYS = ("space play/pause · < > speed · , . -/+10 s · T time · "
        "F failed · R restart · W alert")
_PRECEDENCE = (MarkKind.ALERT, MarkKind.RESTART, MarkKind.ACTION_FAILED)  # last wins a cell


def clock_text(seconds: float) -> str:
    """Seconds as h:mm:ss (or m:ss under an hour)."""
    whole = int(max(seconds, 0.0))
    hours, rest = divmod(whole, 3600)
    return f"{hours}:{rest // 60:02d}:{rest % 60:02d}" if hours else \
        f"{rest // 60}:{rest % 60:02d}"


class TimelineBar(Static):
    """The replay's timeline (module doc)."""

    DEFAULT_CSS = """
    TimelineBar { height: 2; padding: 0 1; background: $panel; }
    """

    class Seek(Message):
        """The operator clicked on the bar: seek to recorded time `t`."""

        def __init__(self, t: float) -> None:
            super().__init__()
            self.t = t

    def __init__(self, player: Player, marks: list[Mark], *, id: str | None = None) -> None:
        super().__init__("", id=id)
        self.player = player
        self.marks = marks
        self.plain = ""  # what it shows (tests)

    def _span(self) -> float:
        return max(self.player.end - self.player.start, 1e-9)

    def show(self) -> None:
        """Draw the state and the bar for the cursor as it is now."""
        player = self.player
        width = max(self.size.width - 2, 10)
        head = Text(no_wrap=True, overflow="ellipsis")
        head.append(f"{STATE_GLYPHS[player.state]} {player.state.value} ", "bold")
        head.append(f"{player.speed:g}x  ")
        head.append(f"{clock_text(player.time - player.start)} / "
                    f"{clock_text(player.end - player.start)}", "bold")
        stamp = time.strftime("%Y-%m-%d %H:%M:%S", time.localtime(player.time))
        head.append(f"  ({stamp})  ", "dim")
        head.append(KEYS, "dim")
        cells: list[tuple[str, str]] = [("─", "dim")] * width
        for kind in _PRECEDENCE:
            for mark in self.marks:
                if mark.kind is kind:
                    cells[self._cell(mark.t, width)] = GLYPHS[kind]
        cursor = self._cell(player.time, width)
        cells[cursor] = ("┃", "bold reverse") if cells[cursor][0] == "─" else \
            (cells[cursor][0], "bold reverse")
        bar = Text(no_wrap=True)
        for style, run in groupby(cells, key=lambda cell: cell[1]):  # a span a run
            bar.append("".join(glyph for glyph, _ in run), style)
        text = Text("\n").join([head, bar])
        self.plain = text.plain
        self.update(text)

    def _cell(self, t: float, width: int) -> int:
        share = (t - self.player.start) / self._span()
        return min(width - 1, max(0, round(share * (width - 1))))

    def on_click(self, event: events.Click) -> None:
        if event.y != 1:
            return
        width = max(self.size.width - 2, 10)
        share = min(max((event.x - 1) / max(width - 1, 1), 0.0), 1.0)
        self.post_message(self.Seek(self.player.start + share * self._span()))

    def on_resize(self, _: events.Resize) -> None:
        self.show()
