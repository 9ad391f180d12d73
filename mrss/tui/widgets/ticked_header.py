"""TickedHeader: Textual's header whose clock moves on with the dashboard's tick.

Textual's `HeaderClock` repaints itself once a second on a timer of its own, which is
a frame of its own (the compositor's whole pass) besides the dashboard's: about a
quarter of the frames `mrss bench tui` counted at 20 msgs/s. This clock is repainted by
the dashboard's once-a-second tick (`tick`), in the frame that tick draws anyway.
"""

from __future__ import annotations

from textual.app import ComposeResult
from textual.events import Mount
from textual.widgets import Header
from textual.widgets._header import HeaderClock, HeaderClockSpace, HeaderIcon, HeaderTitle


class TickedClock(HeaderClock):
    """The time of day, repainted when told (`TickedHeader.tick`), not on a timer."""

    def _on_mount(self, event: Mount) -> None:
        event.prevent_default()  # HeaderClock's own (its timer) is not called


class TickedHeader(Header):
    """Textual's header, its clock moved on by `tick`."""

    def compose(self) -> ComposeResult:
        yield HeaderIcon().data_bind(Header.icon)
        yield HeaderTitle()
        yield (TickedClock().data_bind(Header.time_format) if self._show_clock
               else HeaderClockSpace())

    def tick(self) -> None:
        """The second moved on: repaint the clock (in the frame being drawn anyway)."""
        for clock in self.query(TickedClock):
            clock.refresh()
