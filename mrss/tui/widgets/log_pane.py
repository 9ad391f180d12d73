"""LogPane: log records, supervision events, operator commands and the TUI's notes, a line each.

Periodic traffic (heartbeats, tree and mind snapshots and their requests) is not shown.
The last `MAX_LINES` lines are kept; `lines_text()` returns them as plain text.
"""

from __future__ import annotations

import time
from collections import deque

from rich.text import Text
from textual.widgets import RichLog

from mrss.messages import Command, Envelope, LogRecord, SupEvent

MAX_LINES = 2000
QUIET_COMMANDS = ("mind", "tree")  # the dashboard's own polling
LEVEL_STYLES = {"DEBUG": "dim", "INFO": "", "WARNING": "yellow", "ERROR": "bold red",
                "CRITICAL": "bold red"}
SUP_STYLES = {"start": "green", "restart": "yellow", "exit": "red", "hang": "bold red",
              "escalate": "bold red", "give_up": "bold red", "quarantine": "bold red",
              "release": "green"}


def log_line(env: Envelope) -> Text | None:
    """The line for one bus message, or None if the log does not show it."""
    body = env.body
    stamp = time.strftime("%H:%M:%S", time.localtime(env.ts))
    if isinstance(body, LogRecord):
        style = LEVEL_STYLES.get(body.level.upper(), "")
        return Text.assemble((f"{stamp} ", "dim"), (f"{body.level[:4]:<4} ", style),
                             (f"{body.component}: ", "bold"), (body.message, style))
    if isinstance(body, SupEvent) and body.event != "tree":
        parts = [f"{body.supervisor}/{body.child}" if body.supervisor else body.child]
        if body.pid:
            parts.append(f"pid={body.pid}")
        if body.count:
            parts.append(f"count={body.count}")
        if body.reason:
            parts.append(f"reason={body.reason!r}")
        return Text.assemble((f"{stamp} ", "dim"),
                             (f"sup.{body.event} ", SUP_STYLES.get(body.event, "")),
                             " ".join(parts))
    if isinstance(body, Command) and body.command not in QUIET_COMMANDS:
        args = " ".join(f"{k}={v}" for k, v in body.args.items())
        return Text.assemble((f"{stamp} ", "dim"), (f"ctl.{body.command} ", "cyan"),
                             f"{body.target} {args} (from {env.src})".replace("  ", " "))
    return None


class LogPane(RichLog):
    """A scrolling log of one-line records; `add` takes the lines of one batch."""

    def __init__(self, *, id: str | None = None) -> None:
        super().__init__(id=id, max_lines=MAX_LINES, wrap=False, markup=False)
        self._plain: deque[str] = deque(maxlen=MAX_LINES)

    def add(self, lines: list[Text]) -> None:
        for line in lines[-MAX_LINES:]:
            self._plain.append(line.plain)
            self.write(line)

    def note(self, text: str, *, error: bool = False) -> None:
        """A line from the TUI itself (what the operator did)."""
        stamp = time.strftime("%H:%M:%S")
        self.add([Text.assemble((f"{stamp} ", "dim"), ("tui ", "cyan"),
                                (text, "bold red" if error else ""))])

    def lines_text(self) -> list[str]:
        return list(self._plain)
