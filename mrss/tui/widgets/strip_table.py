"""StripTable: a table of keyed rows that repaints only the rows that changed.

Textual's `DataTable` renders every visible cell again through Rich on any change (its
caches are keyed by an update counter that every change bumps): 9 to 14 ms of CPU per
redraw of a dashboard table, most of what `mrss tui` costs at 20 msgs/s. This table
draws itself line by line (`render_line`, as Textual's `Log` does): each row is turned
into a `Strip` once, from its cells' plain text and style (padded or cut to the column
width with `rich.cells`, no console render), and kept until one of its cells or a
column width changes; a change repaints only the lines of the rows that changed.
Zebra stripes and the cursor are styles put over a row's strip as it is drawn, so a
row moved down by a new row on top is not rendered again.

The rows are given as a whole: `show([(key, cells), ...])`. The cursor stays on its
row's key when rows come or go above it (a cursor on the first row stays there: it
follows the newest row). Up / down / PgUp / PgDn / Home / End move it, a click puts it
on a row; Enter, or a click on the cursor's row, posts `RowSelected`; the cursor coming
to another row's key posts `RowHighlighted`.
"""

from __future__ import annotations

import re
from collections.abc import Sequence
from typing import ClassVar

from rich.cells import cell_len, set_cell_size
from rich.segment import Segment
from rich.style import Style, StyleType
from rich.text import Text
from textual import events
from textual.binding import Binding, BindingType
from textual.geometry import Region, Size
from textual.message import Message
from textual.scroll_view import ScrollView
from textual.strip import Strip

Row = tuple[str, Sequence[Text]]
_CONTROL = re.compile("[\x00-\x1f\x7f]")  # never sent to the terminal as they are
_BLANK = Text()


def _printable(plain: str) -> str:
    """`plain` with control characters (tabs, newlines, escapes) made blanks."""
    return plain if plain.isprintable() else _CONTROL.sub(" ", plain)


def _same(a: Text, b: Text) -> bool:
    """Whether two cells draw the same (`Text.__eq__` ignores the base style)."""
    return a is b or (a.plain == b.plain and a.style == b.style and a.spans == b.spans)


class StripTable(ScrollView, can_focus=True):
    """Rows of cells under a header line, with zebra stripes and a row cursor."""

    COLUMNS: ClassVar[tuple[tuple[str, str], ...]] = ()  # (key, label)
    MAX_WIDTHS: ClassVar[dict[str, int]] = {}  # column key -> at most this many cells
    PAD = 1  # blank cells on each side of a column

    COMPONENT_CLASSES: ClassVar[set[str]] = {
        "strip-table--header", "strip-table--even-row", "strip-table--odd-row",
        "strip-table--cursor",
    }
    DEFAULT_CSS = """
    StripTable {
        background: $surface;
        color: $foreground;
        height: auto;
        max-height: 100%;
        &:focus {
            background-tint: $foreground 5%;
            & > .strip-table--cursor {
                background: $block-cursor-background;
                color: $block-cursor-foreground;
                text-style: $block-cursor-text-style;
            }
            & > .strip-table--header { background-tint: $foreground 5%; }
        }
        &:dark > .strip-table--even-row { background: $surface-darken-1 40%; }
        & > .strip-table--header {
            text-style: bold;
            background: $panel;
            color: $foreground;
        }
        &:ansi > .strip-table--header {
            background: ansi_bright_blue;
            color: ansi_default;
        }
        & > .strip-table--even-row { background: $surface-lighten-1 50%; }
        & > .strip-table--cursor {
            background: $block-cursor-blurred-background;
            color: $block-cursor-blurred-foreground;
            text-style: $block-cursor-blurred-text-style;
        }
    }
    """
    BINDINGS: ClassVar[list[BindingType]] = [
        Binding("enter", "select_cursor", "Select", show=False),
        Binding("up", "cursor_up", "Cursor up", show=False),
        Binding("down", "cursor_down", "Cursor down", show=False),
        Binding("pageup", "page_up", "Page up", show=False),
        Binding("pagedown", "page_down", "Page down", show=False),
        Binding("home,ctrl+home", "cursor_first", "First row", show=False),
        Binding("end,ctrl+end", "cursor_last", "Last row", show=False),
        Binding("left", "scroll_left", "Scroll left", show=False),
        Binding("right", "scroll_right", "Scroll right", show=False),
    ]

    class RowMessage(Message):
        """About one row of `table`: `row_key`, at `cursor_row`."""

        def __init__(self, table: StripTable, cursor_row: int, row_key: str) -> None:
            self.table = table
            self.cursor_row = cursor_row
            self.row_key = row_key
            super().__init__()

        @property
        def control(self) -> StripTable:
            return self.table

    class RowHighlighted(RowMessage):
        """The cursor is on another row."""

    class RowSelected(RowMessage):
        """Enter (or a click) on the cursor's row."""

    def __init__(self, *, id: str | None = None, classes: str | None = None) -> None:
        super().__init__(id=id, classes=classes)
        self._row_keys: list[str] = []
        self._row_cells: dict[str, tuple[Text, ...]] = {}
        self._row_lens: dict[str, tuple[int, ...]] = {}
        self._row_strips: dict[str, Strip] = {}  # rendered rows (lazily, when drawn)
        self._header_strip: Strip | None = None
        self._line_width = 0  # the width rows were rendered to
        self._widths = [cell_len(label) for _, label in self.COLUMNS]
        self._cursor = 0
        self._highlighted: str | None = None
        self._styles_of: dict[StyleType, Style] = {}
        self.draws = 0  # `show` calls (tests watch the redraw rate)
        self.rebuilds = 0  # `show` calls that changed the rows' keys or order
        self.renders = 0  # rows rendered into strips (tests watch that only changes are)

    # -- what the rest of the dashboard uses ------------------------------------------

    @property
    def row_count(self) -> int:
        return len(self._row_keys)

    @property
    def cursor_row(self) -> int:
        return self._cursor

    @property
    def selected_key(self) -> str | None:
        """The key of the row under the cursor, if any."""
        return self._row_keys[self._cursor] if self._row_keys else None

    def shown_keys(self) -> list[str]:
        """The row keys in the order shown."""
        return list(self._row_keys)

    def get_row(self, key: str) -> tuple[Text, ...]:
        """The cells of row `key` (KeyError if it is not shown)."""
        return self._row_cells[key]

    def show(self, rows: Sequence[Row]) -> None:
        """Make the table show exactly `rows`, in order; repaint the rows that changed."""
        self.draws += 1
        keys = [key for key, _ in rows]
        old_keys = self._row_keys
        reordered = keys != old_keys
        selected = self.selected_key if self._cursor > 0 else None  # the top row follows
        cells_of, lens_of, strips = self._row_cells, self._row_lens, self._row_strips
        new_cells: dict[str, tuple[Text, ...]] = {}
        new_lens: dict[str, tuple[int, ...]] = {}
        changed: list[int] = []
        for index, (key, row) in enumerate(rows):
            cells = tuple(row)
            old = cells_of.get(key)
            if old is not None and len(old) == len(cells) and all(
                    map(_same, old, cells)):
                new_cells[key], new_lens[key] = old, lens_of[key]
                continue
            new_cells[key] = cells
            new_lens[key] = tuple(cell_len(_printable(cell.plain)) for cell in cells)
            strips.pop(key, None)
            changed.append(index)
        self._row_cells, self._row_lens = new_cells, new_lens
        if reordered:
            self.rebuilds += 1
            self._row_keys = keys
            for key in set(strips) - set(new_cells):
                del strips[key]
        widened = self._fit_widths(shrink=reordered)
        if reordered:
            self._cursor = keys.index(selected) if selected in new_cells else 0
        self._cursor = min(self._cursor, max(0, len(keys) - 1))
        self._resize()
        if reordered or widened:
            self.refresh()
        else:
            self._refresh_rows(changed)
        self._cursor_moved(scroll=reordered)

    def move_cursor(self, *, row: int | None = None, animate: bool = False) -> None:
        """Put the cursor on row `row` (clamped to the rows shown), scrolled into view."""
        del animate  # never animated: accepted as `DataTable.move_cursor` takes it
        if row is None or not self._row_keys:
            return
        old = self._cursor
        self._cursor = max(0, min(row, len(self._row_keys) - 1))
        if old != self._cursor:
            self._refresh_rows([old, self._cursor])
        self._cursor_moved(scroll=True)

    # -- keys and mouse ------------------------------------------------------------------

    def action_cursor_up(self) -> None:
        self.move_cursor(row=self._cursor - 1)

    def action_cursor_down(self) -> None:
        self.move_cursor(row=self._cursor + 1)

    def action_page_up(self) -> None:
        self.move_cursor(row=self._cursor - self._page())

    def action_page_down(self) -> None:
        self.move_cursor(row=self._cursor + self._page())

    def action_cursor_first(self) -> None:
        self.move_cursor(row=0)

    def action_cursor_last(self) -> None:
        self.move_cursor(row=len(self._row_keys) - 1)

    def action_select_cursor(self) -> None:
        key = self.selected_key
        if key is not None:
            self.post_message(self.RowSelected(self, self._cursor, key))

    def on_click(self, event: events.Click) -> None:
        """A click on a row puts the cursor there; on the cursor's row, selects it."""
        offset = event.get_content_offset(self)
        if offset is None or offset.y == 0:  # the border, or the header
            return
        row = int(self.scroll_y) + offset.y - 1
        if not 0 <= row < len(self._row_keys):
            return
        event.stop()
        if row == self._cursor:
            self.action_select_cursor()
        else:
            self.move_cursor(row=row)

    def _page(self) -> int:
        return max(1, self.scrollable_content_region.height - 1)

    # -- drawing -------------------------------------------------------------------------

    def render_line(self, y: int) -> Strip:
        scroll_x, scroll_y = self.scroll_offset
        width = self.size.width
        if width != self._line_width:  # rows are rendered as wide as the view at least
            self._line_width = width
            self._row_strips.clear()
            self._header_strip = None
        if y == 0:
            if self._header_strip is None:
                self._header_strip = self._render_cells(
                    [Text(label) for _, label in self.COLUMNS])
            body, style = self._header_strip, self.get_component_rich_style(
                "strip-table--header")
            cursor = None
        else:
            index = scroll_y + y - 1
            if index >= len(self._row_keys):
                return Strip.blank(width, self.rich_style)
            key = self._row_keys[index]
            cached = self._row_strips.get(key)
            if cached is None:
                cached = self._row_strips[key] = self._render_cells(self._row_cells[key])
                self.renders += 1
            body = cached
            style = self.get_component_rich_style(
                "strip-table--odd-row" if index % 2 else "strip-table--even-row")
            cursor = (self.get_component_rich_style("strip-table--cursor")
                      if index == self._cursor else None)
        # the crop and the styled line are cached by the row's strip: a row drawn again
        # (moved, or its stripe changed) makes no new strip
        line = body.crop_extend(scroll_x, scroll_x + width, None)
        if cursor is None:
            return line.apply_style(style)
        post = Style.from_color(color=cursor.color)  # the cursor's colour over the cells'
        return Strip(Segment.apply_style(line, style + cursor, post), width)

    def _render_cells(self, cells: Sequence[Text]) -> Strip:
        """One row: each cell's text, padded or cut (with `…`) to its column's width;
        as wide as the table, or the view if that is wider."""
        segments: list[Segment] = []
        pad = " " * self.PAD
        gap = pad  # blanks before the next cell's text
        for column, width in enumerate(self._widths):
            text = cells[column] if column < len(cells) else _BLANK
            if text.spans:  # styled in parts: Rich draws it (not the dashboard's cells)
                fitted = text.copy()
                fitted.plain = _printable(fitted.plain)  # as long: the spans stay
                fitted.truncate(width, overflow="ellipsis", pad=True)
                segments.append(Segment(gap))
                segments.extend(fitted.render(self.app.console))
                gap = pad * 2
                continue
            plain = _printable(text.plain)
            size = cell_len(plain)
            if size > width:
                plain = set_cell_size(plain, width - 1) + "…" if width else ""
                size = width
            if plain:
                segments.append(Segment(gap))
                segments.append(Segment(plain, self._style(text.style)))
                gap = " " * (width - size) + pad * 2
            else:
                gap += " " * width + pad * 2
        table = self._table_width()
        line = max(table, self._line_width)
        segments.append(Segment(gap[: len(gap) - self.PAD] + " " * (line - table)))
        return Strip([segment for segment in segments if segment.text], line)

    def _table_width(self) -> int:
        return sum(self._widths) + 2 * self.PAD * len(self._widths)

    def _style(self, style: StyleType) -> Style:
        known = self._styles_of.get(style)
        if known is None:
            known = self._styles_of[style] = self.app.console.get_style(
                style, default=Style.null())
        return known

    # -- bookkeeping ---------------------------------------------------------------------

    def _fit_widths(self, *, shrink: bool) -> bool:
        """Size each column to its widest cell (or label), at most its `MAX_WIDTHS`.
        Columns only grow while the rows stay in place (a column narrowing every second
        would repaint the whole table); they shrink when the rows change. Whether any
        width changed."""
        widths = [cell_len(label) for _, label in self.COLUMNS]
        count = len(widths)
        for lens in self._row_lens.values():
            for column, size in enumerate(lens[:count]):
                if size > widths[column]:
                    widths[column] = size
        for column, (key, _) in enumerate(self.COLUMNS):
            cap = self.MAX_WIDTHS.get(key)
            if cap is not None and widths[column] > cap:
                widths[column] = cap
        if not shrink:
            widths = [max(a, b) for a, b in zip(widths, self._widths, strict=True)]
        if widths == self._widths:
            return False
        self._widths = widths
        self._row_strips.clear()
        self._header_strip = None
        return True

    def _resize(self) -> None:
        size = Size(self._table_width(), len(self._row_keys) + 1)
        if size != self.virtual_size:
            self.virtual_size = size

    def _refresh_rows(self, indexes: Sequence[int]) -> None:
        """Repaint the lines of these rows, if they are in view."""
        top, height = int(self.scroll_y), self.scrollable_content_region.height
        width = max(self.virtual_size.width, self.size.width)
        regions = [Region(0, index + 1 - top, width, 1) for index in set(indexes)
                   if 1 <= index + 1 - top < height]
        if regions:
            self.refresh(*regions)

    def _cursor_moved(self, *, scroll: bool) -> None:
        """Scroll the cursor's row into view; say so when it is on another row."""
        if not self._row_keys:
            self._highlighted = None
            return
        if scroll and self.is_mounted:
            view = self.scrollable_content_region.height - 1  # rows under the header
            top = int(self.scroll_y)
            if self._cursor < top:
                self.scroll_to(y=self._cursor, animate=False, force=True)
            elif view > 0 and self._cursor >= top + view:
                self.scroll_to(y=self._cursor - view + 1, animate=False, force=True)
        key = self._row_keys[self._cursor]
        if key != self._highlighted:
            self._highlighted = key
            self.post_message(self.RowHighlighted(self, self._cursor, key))
