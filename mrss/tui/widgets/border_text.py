"""A panel's border title and subtitle, changed without repainting the whole panel.

Textual repaints every line of a widget when its `border_title` or `border_subtitle`
is set, even to the same text: a table whose subtitle is set at every redraw, or the
mind panel whose subtitle names the snapshot's time, was painted whole each second
(most of the lines the dashboard painted were unchanged, `mrss bench tui`). Here a
text equal to the one shown changes nothing, and a new one repaints only the border
line it is on (top for the title, bottom for the subtitle). The text is plain (no
markup). A widget not mounted yet, or without a border, takes the text the ordinary way.
"""

from __future__ import annotations

from typing import Literal

from rich.text import Text
from textual.content import Content
from textual.geometry import Region
from textual.widget import Widget

Edge = Literal["title", "subtitle"]


def set_border_title(widget: Widget, text: str) -> None:
    """`widget.border_title = text`, repainting only the top border line."""
    _set(widget, "title", text)


def set_border_subtitle(widget: Widget, text: str) -> None:
    """`widget.border_subtitle = text`, repainting only the bottom border line."""
    _set(widget, "subtitle", text)


def _set(widget: Widget, edge: Edge, text: str) -> None:
    shown: dict[Edge, str] = widget.__dict__.setdefault("_mrss_border_text", {})
    if shown.get(edge) == text:
        return
    shown[edge] = text
    attribute = f"_border_{edge}"
    top, _, bottom, _ = widget.styles.border.spacing
    has_line = top if edge == "title" else bottom
    if not widget.is_mounted or not has_line or not widget.size:
        # the descriptor (a full repaint), given the text as plain text
        setattr(widget, f"border_{edge}", Text(text) if text else None)
        return
    # plain text, its first line (as the descriptor keeps it), never markup: parsing
    # markup was most of what setting a text cost
    setattr(widget, attribute, Content(text.splitlines()[0]).expand_tabs(4) if text else None)
    # the line in the widget's own coordinates, given in its content's (refresh adds
    # the content offset back)
    outer = widget.outer_size
    offset = widget.content_offset
    y = 0 if edge == "title" else outer.height - 1
    widget.refresh(Region(-offset.x, y - offset.y, outer.width, 1))
