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

from typing import TYPE_CHECKING

from textual.geometry import Size
from textual.reactive import Reactive
from textual.widget import Widget

# A plain mixin at run time: a Widget base would hide the Textual class's component
# classes (a DataTable's header and cursor styles) from the subclass.
if TYPE_CHECKING:
    from textual.widget import Widget as _Base
else:
    _Base = object


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
            self.vertical_scrollbar.window_virtual_size = size.height
        if self.show_horizontal_scrollbar:
            self.horizontal_scrollbar.window_virtual_size = size.width
        if self.scroll_y > self.max_scroll_y:  # the content shrank under the view
            self.scroll_y = self.max_scroll_y
        if self.scroll_x > self.max_scroll_x:
            self.scroll_x = self.max_scroll_x
