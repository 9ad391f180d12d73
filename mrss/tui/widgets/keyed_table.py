"""KeyedTable: a DataTable shown from a list of (key, cells) rows, the cursor kept on its row.

Each panel computes the rows it wants from its model and calls `show(rows)`. When the
keys and their order are unchanged only the changed cells are updated; otherwise the
table is rebuilt and the cursor moved back to the row it was on, so an operator's
selection does not jump when new rows appear above it (a cursor on the first row stays
there: it follows the newest row).
"""

from __future__ import annotations

from collections.abc import Iterator, Sequence

from rich.console import Console, ConsoleOptions
from rich.segment import Segment
from rich.text import Text
from textual.widgets import DataTable

from mrss.tui.widgets.steady_scroll import SteadyScroll

Row = tuple[str, Sequence[Text]]


class KeyedTable(SteadyScroll, DataTable[Text]):
    """A row-cursor DataTable whose rows are replaced as a whole by `show`."""

    COLUMNS: tuple[tuple[str, str], ...] = ()  # (key, label)

    def __init__(self, *, id: str | None = None) -> None:
        super().__init__(id=id, cursor_type="row", zebra_stripes=True)
        self.rebuilds = 0  # how many times `show` had to rebuild (tests watch batching)
        self.reorders = 0  # how many times it added / removed rows and sorted instead
        self.draws = 0  # how many times `show` was called (tests watch the redraw rate)

    def on_mount(self) -> None:
        for key, label in self.COLUMNS:
            self.add_column(label, key=key)

    @property
    def selected_key(self) -> str | None:
        """The key of the row under the cursor, if any."""
        if not self.row_count:
            return None
        row_key, _ = self.coordinate_to_cell_key(self.cursor_coordinate)
        return row_key.value

    def shown_keys(self) -> list[str]:
        """The row keys in the order shown."""
        return [str(row.key.value) for row in self.ordered_rows]

    def show(self, rows: Sequence[Row]) -> None:
        """Make the table show exactly `rows`, in order."""
        self.draws += 1
        keys = [key for key, _ in rows]
        shown = self.shown_keys()
        if keys == shown:
            self._update_cells(rows)
            return
        selected = self.selected_key if self.cursor_row > 0 else None  # the top row follows
        firsts = [cells[0].plain if cells else "" for _, cells in rows]
        kept = set(shown) & set(keys)
        if len(set(firsts)) == len(firsts) and len(kept) * 2 >= len(shown) > 0:
            # Mostly the same rows (new ones on top, old ones gone): add and remove those
            # and sort, so the table measures only the new rows, not every row again
            # (a rebuild of 200 rows is the costliest frame at 1,000 msgs/s).
            self.reorders += 1
            for key in set(shown) - kept:
                self.remove_row(key)
            self._update_cells([row for row in rows if row[0] in kept])
            for key, cells in rows:
                if key not in kept:
                    self.add_row(*cells, key=key)
            order = {first: i for i, first in enumerate(firsts)}
            self.sort(key=lambda values: order.get(values[0].plain, len(order)))
        else:
            self.rebuilds += 1
            self.clear()
            for key, cells in rows:
                self.add_row(*cells, key=key)
        self.move_cursor(row=keys.index(selected) if selected in keys else 0, animate=False)

    def _update_cells(self, rows: Sequence[Row]) -> None:
        columns = [key for key, _ in self.COLUMNS]
        widths = {key.value: column.content_width for key, column in self.columns.items()}
        for key, cells in rows:
            old = self.get_row(key)
            for column, before, after in zip(columns, old, cells, strict=False):
                if before != after:
                    # Only a wider cell resizes its column: a narrower one would make the
                    # table measure the whole column again (columns shrink at rebuilds).
                    wider = after.cell_len > widths.get(column, 0)
                    self.update_cell(key, column, after, update_width=wider)
                    if wider:
                        widths[column] = after.cell_len


class Cell(Text):
    """A table cell's text, drawn without Rich's line wrapping when it fits on its line:
    a `DataTable` draws every visible cell again on any change, and skipping the
    wrapping makes that about a sixth cheaper. What is drawn is the same."""

    def __rich_console__(self, console: Console, options: ConsoleOptions
                         ) -> Iterator[Segment]:
        plain = self.plain
        if not plain and not self.spans:
            yield Segment(self.end)  # nothing to draw: the line ends
        elif (self.justify or options.justify or "default") == "default" \
                and "\n" not in plain and "\t" not in plain \
                and self.cell_len <= options.max_width:
            # `render` leaves the base style to the caller (wrapping makes it a span)
            yield from Segment.apply_style(self.render(console, end=self.end),
                                           console.get_style(self.style))
        else:
            yield from super().__rich_console__(console, options)


def cell(text: object, style: str = "") -> Text:
    """A table cell: plain text (never markup), optionally styled."""
    return Cell(str(text), style=style, no_wrap=True, overflow="ellipsis")


def age_text(seconds: float) -> str:
    """`3s`, `4m`, `2h`: how long ago."""
    s = int(seconds)
    if s < 60:
        return f"{s}s"
    return f"{s // 60}m" if s < 3600 else f"{s // 3600}h"
