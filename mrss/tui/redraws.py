"""When the dashboard's tables are redrawn. A base of `MrssApp`.

Each redraw is a frame, so a table (and the map) is redrawn at most about once a
`table_every` seconds (`mrss bench tui`): a drain that changes what it shows redraws
it at once if it was drawn longer ago than that, else when the one pending redraw
comes, which draws every panel that became due meanwhile in the same frame. Once a
second the tick redraws the tables not drawn recently (ages and uptimes move on) and
the banner.
"""

from __future__ import annotations

import time
from collections.abc import Callable
from contextlib import suppress

from textual.app import App
from textual.css.query import NoMatches
from textual.timer import Timer

from mrss.tui.widgets.actions_table import ActionsTable
from mrss.tui.widgets.map_panel import MapPanel
from mrss.tui.widgets.mission_panel import MissionPanel
from mrss.tui.widgets.robots_table import RobotsTable
from mrss.tui.widgets.supervision_table import SupervisionTable

TABLES = ("supervision", "robots", "actions", "mission")  # ticked: their ages move on
PANELS = (*TABLES, "map")  # redrawn at most every table_every
TICK_SKIP = 0.9  # the second's tick leaves a table redrawn this recently (x table_every)


class TableRedraws(App[None]):
    """Schedules table redraws; `table_every`, `_drawn`, `_table_due` are the app's."""

    clock: Callable[[], float]
    table_every: float
    _drawn: dict[str, float]
    _table_due: set[str]
    _due_timer: Timer | None = None

    def _show_liveness(self) -> None:
        raise NotImplementedError

    def _tick(self) -> None:
        """Once a second: uptimes, ages and the connection state move on."""
        now = self.clock()
        recent = time.monotonic() - TICK_SKIP * self.table_every
        with suppress(NoMatches):  # the panels are gone: the app is closing
            for table in TABLES:
                # drawn just now, or a redraw is due soon anyway: skip
                if self._drawn.get(table, 0.0) < recent and table not in self._table_due:
                    self._draw_table(table, now)
            self._show_liveness()

    def _table_changed(self, table: str, now: float) -> None:
        """A drain changed what `table` (or the map) shows: redraw it now, or (drawn less
        than `table_every` ago) with the pending redraw, set for when its time is up."""
        wait = self._drawn.get(table, -self.table_every) + self.table_every - time.monotonic()
        if wait <= 0 and table not in self._table_due:
            self._draw_table(table, now)
            return
        self._table_due.add(table)
        if self._due_timer is None:  # one timer, one frame, for every panel due by then
            self._due_timer = self.set_timer(max(wait, 0.0), self._draw_due)

    def _draw_due(self) -> None:
        self._due_timer = None
        due, self._table_due = self._table_due, set()
        now = self.clock()
        with suppress(NoMatches):  # the panels are gone: the app is closing
            for table in PANELS:
                if table in due:
                    self._draw_table(table, now)

    def _draw_table(self, table: str, now: float) -> None:
        self._drawn[table] = time.monotonic()
        if table == "map":
            self.query_one(MapPanel).refresh()
            return
        widgets: dict[str, type[ActionsTable | RobotsTable | SupervisionTable | MissionPanel]]
        widgets = {"actions": ActionsTable, "robots": RobotsTable,
                   "supervision": SupervisionTable, "mission": MissionPanel}
        self.query_one(widgets[table]).refresh_rows(now)

