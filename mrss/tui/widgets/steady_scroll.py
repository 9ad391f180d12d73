"""SteadyScroll: a scrolling panel whose content growing does not lay out the whole screen.

Textual lays the whole screen out again (and repaints every panel) whenever a widget's
virtual (scrollable) size changes: each new log line, each new table row or wider
column. That is half of what the dashboard spends painting (`mrss bench tui`). A panel
whose own size does not depend on its content (neither its width nor its height is
`auto`) needs that only when one of its scrollbars appears or disappears; otherwise
its scrollbars' thumbs are updated and the panel alone is repainted. A panel of `auto`
height needs it when its content gets taller or shorter, not wider (and the other
way round for an `auto` width).

Mix it in before the Textual class: `class LogView(SteadyScroll, RichLog)`.
"""

from __future__ import annotations

from math import ceil
from typing import TYPE_CHECKING

from textual.geometry import Size
from textual.reactive import Reactive
from textual.scrollbar import ScrollBar
from textual.widget import Widget

# A plain mixin at run time: a Widget base would hide the Textual class's component
# classes (a DataTable's header and cursor styles) from the subclass.
if TYPE_CHECKING:
    from textual.widget import Widget as _Base
else:
    _Base = object


EIGHTHS = 8  # the partial-cell glyphs a scrollbar's thumb ends in (Textual's bars)


def _shown(overflow: str, over: bool) -> bool:
    return overflow == "scroll" or (overflow == "auto" and over)


def scrollbars_for(widget: Widget, size: Size) -> tuple[bool, bool]:
    """(horizontal, vertical): the scrollbars `widget` shows for a virtual size `size`
    (Textual's rule: one scrollbar shown narrows the room left for the other)."""
    styles = widget.styles
    width, height = widget.container_size
    horizontal = _shown(styles.overflow_x, size.width > width)
    vertical = _shown(styles.overflow_y, size.height > height)
    if styles.overflow_x == "auto" and vertical and not horizontal:
        horizontal = size.width > width - styles.scrollbar_size_vertical
    if styles.overflow_y == "auto" and horizontal and not vertical:
        vertical = size.height > height - styles.scrollbar_size_horizontal
    return horizontal, vertical


class SteadyScroll(_Base):
    """Lays the screen out on a virtual size change only when it can change the layout."""

    virtual_size: Reactive[Size] = Reactive(Size(0, 0), layout=False)
    relayouts = 0  # virtual size changes that did lay the screen out (tests watch it)

    def watch_scroll_y(self, old: float, new: float) -> None:
        """Textual's, with the scrollbar repainted only if its thumb moves an eighth of
        a cell (a log following its end scrolls a line each line)."""
        if self.show_vertical_scrollbar:
            _move_thumb(self.vertical_scrollbar, new)
        super().watch_scroll_y(old, new)

    def watch_scroll_x(self, old: float, new: float) -> None:
        if self.show_horizontal_scrollbar:
            _move_thumb(self.horizontal_scrollbar, new)
        super().watch_scroll_x(old, new)

    def watch_virtual_size(self, old: Size, size: Size) -> None:
        styles = self.styles
        # a panel sized by its content (`height: auto`) changes size with it (the extent
        # that sizes it, not the other: a wider row does not make a table taller), unless
        # its content overflows the panel before and after: it is at its `max-height`
        # already (a table of actions growing a row at a time, `mrss bench tui`)
        view = self.scrollable_content_region.size
        sized_by_content = any(
            scalar is not None and scalar.is_auto and before != after
            and not (before > shown and after > shown)
            for scalar, before, after, shown in (
                (styles.width, old.width, size.width, view.width),
                (styles.height, old.height, size.height, view.height)))
        if (sized_by_content or not self.container_size
                or scrollbars_for(self, size) != (self.show_horizontal_scrollbar,
                                                  self.show_vertical_scrollbar)):
            self.relayouts += 1
            self.refresh(layout=True)
            return
        if self.show_vertical_scrollbar:
            _resize_thumb(self.vertical_scrollbar, size.height)
        if self.show_horizontal_scrollbar:
            _resize_thumb(self.horizontal_scrollbar, size.width)
        if self.scroll_y > self.max_scroll_y:  # the content shrank under the view
            self.scroll_y = self.max_scroll_y
        if self.scroll_x > self.max_scroll_x:
            self.scroll_x = self.max_scroll_x


def _thumb(bar: ScrollBar, virtual_size: float,
           position: float | None = None) -> tuple[int, int] | None:
    """Where a scrollbar's thumb is drawn, in eighths of a cell (start, end), for
    `virtual_size` and `position` (default: the bar's; None: no thumb); as Textual's
    `ScrollBarRender.render_bar` puts it."""
    size = bar.size.height if bar.vertical else bar.size.width
    virtual = ceil(virtual_size)
    window = ceil(bar.window_size) if bar.window_size < virtual_size else 0
    if not (window and size and virtual and size != virtual) or virtual <= window:
        return None
    thumb = max(1, window / (virtual / size))
    at = bar.position if position is None else position
    position = (size - thumb) * (at / (virtual - window))
    start = int(position * EIGHTHS)
    return start, start + ceil(thumb * EIGHTHS)


def _resize_thumb(bar: ScrollBar, virtual_size: int) -> None:
    """`bar.window_virtual_size = virtual_size`, repainting the scrollbar only if its
    thumb moves or changes size by an eighth of a cell: a log or table a line longer
    mostly leaves it where it was (a scrollbar repainted whole for it was the most
    lines the dashboard painted, `mrss bench tui`)."""
    if bar.window_virtual_size == virtual_size:
        return
    before = _thumb(bar, bar.window_virtual_size)
    if before is not None and before == _thumb(bar, virtual_size):
        bar.set_reactive(ScrollBar.window_virtual_size, virtual_size)
    else:
        bar.window_virtual_size = virtual_size


def _move_thumb(bar: ScrollBar, position: float) -> None:
    """Set `bar.position` without a repaint when its thumb stays where it is drawn (the
    watcher that follows sets it again, to the same value: nothing happens)."""
    value = bar.validate_position(position)
    if value == bar.position:
        return
    before = _thumb(bar, bar.window_virtual_size)
    if before is not None and before == _thumb(bar, bar.window_virtual_size, value):
        bar.set_reactive(ScrollBar.position, value)
