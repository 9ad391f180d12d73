"""Where the panels go, at any terminal size.

Wide enough (at least `COMPACT_WIDTH` x `COMPACT_HEIGHT`, e.g. 120 x 35) every panel
shows at once, in three rows. Smaller (80 x 24) the dashboard is compact: one panel at
a time, under a tab line naming them all with their keys; `1`..`7` (or Tab, which
moves the focus) switch panel. At any size `z` maximises the focused panel to the
whole screen and back, so nothing is cut without a way to see it in full.

`PanelLayout` is held by `MrssApp`, whose `BINDINGS` begin with `LAYOUT_BINDINGS` and
whose `action_show_panel`, `action_maximise`, `on_resize` and `on_descendant_focus`
hand over to it.
"""

from __future__ import annotations

from contextlib import suppress

from rich.text import Text
from textual.app import App
from textual.binding import Binding, BindingType
from textual.css.query import NoMatches
from textual.widget import Widget
from textual.widgets import Static

# (panel id, tab name), in key order 1..7
PANELS = (("supervision", "Supervision"), ("robots", "Robots"), ("map", "Map"),
          ("actions", "Actions"), ("mission", "Mission"), ("mind", "Mind"), ("log", "Log"))
COMPACT_WIDTH = 120  # below either, one panel at a time
COMPACT_HEIGHT = 35
LAYOUT_BINDINGS: list[BindingType] = [
    *(Binding(str(i), f"show_panel('{ident}')", name, show=False)
      for i, (ident, name) in enumerate(PANELS, 1)),
    Binding("z", "maximise", "Maximise / restore"),
]


def is_compact(width: int, height: int) -> bool:
    return width < COMPACT_WIDTH or height < COMPACT_HEIGHT


def tab_line(current: str) -> Text:
    """`1 Supervision  2 Robots ...` with the current panel highlighted."""
    text = Text()
    for i, (ident, name) in enumerate(PANELS, 1):
        style = "bold reverse" if ident == current else "dim"
        text.append(f" {i} {name} ", style=style)
    return text


class PanelLayout:
    """The compact mode and the panel shown in it, on the screen of `app` (the panels
    are its widgets with the ids of `PANELS`, in the rows `#top`, `#middle`, `#bottom`,
    under the tab line `#tabs`)."""

    def __init__(self, app: App[None]) -> None:
        self.app = app
        self.compact = False
        self.current_panel = "actions"

    def panel(self, ident: str) -> Widget:
        return self.app.query_one(f"#{ident}")

    def set_compact(self, compact: bool) -> None:
        self.compact = compact
        with suppress(NoMatches):
            self.app.query_one("#tabs", Static).display = compact
            self._show_current()

    def _show_current(self) -> None:
        for ident, _ in PANELS:
            self.panel(ident).display = not self.compact or ident == self.current_panel
        for row in ("top", "middle", "bottom"):
            container = self.app.query_one(f"#{row}")
            container.display = any(child.display for child in container.children)
        self.app.query_one("#tabs", Static).update(tab_line(self.current_panel))

    def show_panel(self, ident: str) -> None:
        """`1`..`7`: show (compact) and focus that panel."""
        self.current_panel = ident
        with suppress(NoMatches):
            self._show_current()
            widget = self.panel(ident)
            target = widget if widget.can_focus else next(
                (w for w in widget.query("*") if w.can_focus and w.display), widget)
            target.focus()

    def focus_moved(self, focused: Widget) -> None:
        """Tab moves the focus; in compact mode the panel holding it is the one shown."""
        node: Widget | None = focused
        while node is not None and node.id not in dict(PANELS):
            parent = node.parent
            node = parent if isinstance(parent, Widget) else None
        if node is not None and node.id and node.id != self.current_panel:
            self.current_panel = node.id
            with suppress(NoMatches):
                self._show_current()

    def maximise(self) -> None:
        """`z`: the focused panel fills the screen; `z` again (or Esc) restores."""
        screen = self.app.screen
        if screen.maximized is not None:
            screen.minimize()
            return
        with suppress(NoMatches):
            screen.maximize(self.panel(self.current_panel), container=False)
