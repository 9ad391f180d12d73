"""KeyedTable: the dashboard's tables, shown from a list of (key, cells) rows.

Each panel computes the rows it wants from its model and calls `show(rows)`; the table
(a `StripTable`) repaints only the rows whose cells changed, and keeps the cursor on its
row's key, so an operator's selection does not jump when new rows appear above it (a
cursor on the first row stays there: it follows the newest row). `SteadyScroll` spares
the screen a layout when a new row changes only the table's scrollable size.
"""

from __future__ import annotations

from rich.text import Text

from mrss.tui.widgets.steady_scroll import SteadyScroll
from mrss.tui.widgets.strip_table import Row, StripTable

__all__ = ["KeyedTable", "Row", "age_text", "cell"]


class KeyedTable(SteadyScroll, StripTable):
    """A row-cursor table whose rows are replaced as a whole by `show`."""


def cell(text: object, style: str = "") -> Text:
    """A table cell: plain text (never markup), optionally styled."""
    return Text(str(text), style=style, no_wrap=True, overflow="ellipsis")


def age_text(seconds: float) -> str:
    """`3s`, `4m`, `2h`: how long ago."""
    s = int(seconds)
    if s < 60:
        return f"{s}s"
    return f"{s // 60}m" if s < 3600 else f"{s // 3600}h"
