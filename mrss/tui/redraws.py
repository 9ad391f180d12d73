"""When the dashboard's tables are redrawn.

Each redraw is a frame, so a table (and the map) is redrawn at most about once a
`table_every` seconds (`mrss bench tui`): a drain that changes what it shows redraws
it at once if it was drawn longer ago than that (or within a tenth of it: drains come
about as often), else when the one pending redraw comes, which draws every panel
that became due meanwhile in the same frame. Once a second the tick redraws the
tables not drawn recently (ages and uptimes move on).
"""

from __future__ import annotations

import time
from collections.abc import Callable, Collection
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
SCHEDULED = (*TABLES, "map")  # redrawn at most every table_every
#: A change this close (x table_every) to a table's next redraw redraws it now, in the
#: frame of the drain that brought it (drains come about as often as redraws may)
DUE_SLACK = 0.1
TICK_SKIP = 0.9  # the second's tick leaves a table redrawn this recently (x table_every)
WIDGETS: dict[str, type[ActionsTable | RobotsTable | SupervisionTable | MissionPanel]] = {
    "actions": ActionsTable, "robots": RobotsTable, "supervision": SupervisionTable,
    "mission": MissionPanel}


class Redraws:
    """Schedules the redraws of the panels of `app` (its one widget of each `WIDGETS`
    type and its `MapPanel`); `clock` is the wall-clock time the rows' ages count to."""

    def __init__(self, app: App[None], *, table_every: float,
                 clock: Callable[[], float]) -> None:
        self.app = app
        self.clock = clock
        self.table_every = table_every  # seconds: a table is redrawn at most this often
        self._drawn: dict[str, float] = {}  # table -> when it was last redrawn (monotonic)
        self._due: set[str] = set()  # tables with a redraw scheduled
        self._due_timer: Timer | None = None

    def tick(self) -> None:
        """Once a second: uptimes and ages move on (raises NoMatches once the panels
        are gone)."""
        now = self.clock()
        recent = time.monotonic() - TICK_SKIP * self.table_every
        for table in TABLES:
            # drawn just now, or a redraw is due soon anyway: skip
            if self._drawn.get(table, 0.0) < recent and table not in self._due:
                self._draw(table, now)

    def changed(self, dirty: Collection[str]) -> None:
        """A drain changed what the panels in `dirty` show (other names are ignored)."""
        now = self.clock()
        for table in SCHEDULED:
            if table in dirty:
                self._changed(table, now)

    def _changed(self, table: str, now: float) -> None:
        """Redraw `table` (or the map) now, or (drawn less than `table_every` ago) with
        the pending redraw, set for when its time is up."""
        wait = self._drawn.get(table, -self.table_every) + self.table_every - time.monotonic()
        if wait <= DUE_SLACK * self.table_every and table not in self._due:
            self._draw(table, now)
            return
        self._due.add(table)
        if self._due_timer is None:  # one timer, one frame, for every panel due by then
            self._due_timer = self.app.set_timer(max(wait, 0.0), self._draw_due)

    def _draw_due(self) -> None:
        self._due_timer = None
        due, self._due = self._due, set()
        now = self.clock()
        with suppress(NoMatches):  # the panels are gone: the app is closing
            for table in SCHEDULED:
                if table in due:
                    self._draw(table, now)

    def _draw(self, table: str, now: float) -> None:
        self._drawn[table] = time.monotonic()
        if table == "map":
            self.app.query_one(MapPanel).redraw()
            return
        self.app.query_one(WIDGETS[table]).refresh_rows(now)
