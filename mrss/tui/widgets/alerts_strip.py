"""AlertsStrip: the newest unacknowledged alerts on one line, red; `A` acknowledges them.

When everything is acknowledged it shows the latest alert dimmed and how many the
history holds (the log pane has every alert as a line too).
"""

from __future__ import annotations

import logging
import time

from rich.text import Text
from textual.widgets import Static

from mrss.tui.models.alerts import Alert, AlertsModel
from mrss.tui.models.logfilter import LogEntry

SHOWN = 4  # unacknowledged alerts named on the strip


class AlertsStrip(Static):
    """One line of alerts under the banner."""

    DEFAULT_CSS = """
    AlertsStrip { height: 1; padding: 0 1; background: $panel; }
    AlertsStrip.-new { background: $warning-darken-3; }
    """

    def __init__(self, model: AlertsModel, *, id: str | None = None) -> None:
        super().__init__("", id=id)
        self.model = model
        self.plain = ""  # the strip's text (tests, captures)

    def show_alerts(self) -> None:
        new = self.model.unacked()
        text = Text(no_wrap=True, overflow="ellipsis")
        if new:
            text.append(f"⚠ {len(new)} new (A acknowledge): ", "bold")
            for i, alert in enumerate(new[:SHOWN]):
                if i:
                    text.append(" · ")
                text.append(alert.line(), "bold red" if alert.severe else "bold yellow")
            if len(new) > SHOWN:
                text.append(f" · +{len(new) - SHOWN} more")
        else:
            history = self.model.history()
            text.append("alerts: none new", "dim")
            if history:
                text.append(f" ({len(history)} in history; latest: {history[0].line()})", "dim")
        self.set_class(bool(new), "-new")
        self.plain = text.plain
        self.update(text)


def alert_line(alert: Alert, ts: float) -> LogEntry:
    """The log pane's line for a raised alert (the history, next to what caused it)."""
    stamp = time.strftime("%H:%M:%S", time.localtime(ts))
    style = "bold red" if alert.severe else "bold yellow"
    return LogEntry(Text.assemble((f"{stamp} ", "dim"), ("alert ", style), alert.line()),
                    logging.WARNING, alert.subject)
