"""MrssApp: the monitoring and debug dashboard of a running MRSS system (`mrss tui PROJECT`).

Panels: the supervision tree, the robots, the actions, the reasoner's mind and a log;
under them the operator's percept line. The app owns the `BusLink` and the models:
bus messages are drained from the link's inbox on the app's thread (at most every
`min_refresh` seconds, so a burst becomes one redraw), applied to the models, and the
panels that changed are redrawn. Widgets ask for bus messages with `SendRequested`.
"""

from __future__ import annotations

import time
from contextlib import suppress
from typing import ClassVar

from rich.text import Text
from textual.app import App, ComposeResult
from textual.binding import Binding, BindingType
from textual.containers import Horizontal
from textual.css.query import NoMatches
from textual.widgets import Footer, Header, Input

from mrss.bus import BusEndpoints
from mrss.messages import (
    ActionRequest,
    ActionStatus,
    Envelope,
    MindSnapshot,
    RobotData,
    RobotState,
    SupEvent,
)
from mrss.tui import operator
from mrss.tui.buslink import BusLink
from mrss.tui.events import BusActivity, Note, SendRequested
from mrss.tui.models.actions import ActionsModel
from mrss.tui.models.robots import RobotsModel
from mrss.tui.models.supervision import SupervisionModel
from mrss.tui.widgets.actions_table import ActionsTable
from mrss.tui.widgets.log_pane import LogPane, log_line
from mrss.tui.widgets.mind_inspector import MindInspector
from mrss.tui.widgets.operator_bar import OperatorBar
from mrss.tui.widgets.robots_table import RobotsTable
from mrss.tui.widgets.supervision_table import SupervisionTable


class MrssApp(App[None]):
    """The dashboard; see the module docstring."""

    TITLE = "MRSS"
    CSS = """
    #top, #bottom { height: 1fr; }
    #actions { height: 1fr; }
    .panel { border: round $primary-darken-2; border-title-color: $accent; }
    .panel:focus-within { border: round $accent; }
    #supervision, #mind { width: 1fr; }
    #robots, #log { width: 1fr; }
    """
    BINDINGS: ClassVar[list[BindingType]] = [
        Binding("m", "mind", "Mind now"),
        Binding("a", "auto_mind", "Auto mind on/off"),
        Binding("p", "focus_percept", "Percept"),
        Binding("escape", "focus_actions", "Actions", show=False),
        Binding("f5", "tree", "Refresh tree"),
        Binding("q", "quit", "Quit"),
    ]

    def __init__(self, endpoints: BusEndpoints, *, project: str = "", agent: str = "",
                 mind_every: float = 1.0, tree_every: float = 2.0,
                 min_refresh: float = 0.1) -> None:
        super().__init__()
        self.project = project
        self.agent = agent
        self.link = BusLink(endpoints)
        self.supervision = SupervisionModel(root=project)
        self.robots = RobotsModel()
        self.actions = ActionsModel()
        self.auto_mind = mind_every > 0
        self.mind_every = mind_every
        self.tree_every = tree_every
        self.min_refresh = min_refresh
        self.flushes = 0  # drains that found messages (tests check batching with it)
        self._last_drain = 0.0
        self._drain_pending = False

    # -- layout -----------------------------------------------------------------------------
    def compose(self) -> ComposeResult:
        yield Header(show_clock=True)
        with Horizontal(id="top"):
            yield SupervisionTable(self.supervision, id="supervision")
            yield RobotsTable(self.robots, id="robots")
        yield ActionsTable(self.actions, id="actions")
        with Horizontal(id="bottom"):
            yield MindInspector(id="mind")
            yield LogPane(id="log")
        yield OperatorBar(id="operator")
        yield Footer()

    def on_mount(self) -> None:
        titles = {"supervision": "Supervision (k kill, h hang, x crash: press twice)",
                  "robots": "Robots (t teleop)", "actions": "Actions (c cancel, s suspend, "
                  "r resume)", "mind": "Mind (m refresh, a auto)", "log": "Log"}
        for ident, title in titles.items():
            widget = self.query_one(f"#{ident}")
            widget.add_class("panel")
            widget.border_title = title
        self.sub_title = self._connection_text()
        self.link.start(wake=lambda: self.post_message(BusActivity()))
        self.set_interval(1.0, self._tick)
        if self.mind_every > 0:
            self.set_interval(self.mind_every, self._poll_mind)
        if self.tree_every > 0:
            self.set_interval(self.tree_every, self._poll_tree)
        self._poll_tree()
        self.query_one("#actions").focus()

    def on_unmount(self) -> None:
        self.link.close()

    # -- bus traffic ------------------------------------------------------------------------
    def on_bus_activity(self, _: BusActivity) -> None:
        self._drain_bus()

    def _drain_bus(self) -> None:
        wait = self._last_drain + self.min_refresh - time.monotonic()
        if wait > 0:
            if not self._drain_pending:
                self._drain_pending = True
                self.set_timer(wait, self._timed_drain)
            return
        self._last_drain = time.monotonic()
        envelopes = self.link.drain()
        if envelopes:
            self.flushes += 1
            with suppress(NoMatches):  # the panels are gone: the app is closing
                self.apply(envelopes)

    def _timed_drain(self) -> None:
        self._drain_pending = False
        self._drain_bus()

    def apply(self, envelopes: list[Envelope]) -> None:
        """Apply a batch of bus messages to the models, then redraw what changed."""
        dirty: set[str] = set()
        lines: list[Text] = []
        mind: Envelope | None = None
        for env in envelopes:
            body = env.body
            if isinstance(body, ActionStatus):
                self.actions.apply_status(body, env.ts)
                dirty.add("actions")
            elif isinstance(body, ActionRequest):
                self.actions.apply_request(body, env.ts)
                dirty.add("actions")
            elif isinstance(body, RobotState):
                self.robots.apply_state(body)
                dirty.add("robots")
            elif isinstance(body, RobotData):
                self.robots.apply_data(body, env.ts)
                dirty.add("robots")
            elif isinstance(body, SupEvent):
                self.supervision.apply_event(body, env.src, env.ts)
                dirty.add("supervision")
            elif isinstance(body, MindSnapshot) and body.agent in ("", self.agent or body.agent):
                mind = env
            line = log_line(env)
            if line is not None:
                lines.append(line)
        now = time.time()
        if "actions" in dirty:
            self.query_one(ActionsTable).refresh_rows()
        if "robots" in dirty:
            self.query_one(RobotsTable).refresh_rows(now)
        if "supervision" in dirty:
            self.query_one(SupervisionTable).refresh_rows(now)
        if mind is not None and isinstance(mind.body, MindSnapshot):
            self.query_one(MindInspector).show_snapshot(mind.body, mind.ts)
        if lines:
            self.query_one(LogPane).add(lines)

    def _tick(self) -> None:
        """Once a second: uptimes, data ages and the connection state move on."""
        now = time.time()
        with suppress(NoMatches):  # the panels are gone: the app is closing
            self.query_one(SupervisionTable).refresh_rows(now)
            self.query_one(RobotsTable).refresh_rows(now)
        self.sub_title = self._connection_text()

    def _connection_text(self) -> str:
        state = "connected" if self.link.connected else "waiting for the bus proxy"
        project = f"{self.project} · " if self.project else ""
        return f"{project}{state} · {self.link.endpoints.backend} · {self.link.received} msgs"

    # -- operator ---------------------------------------------------------------------------
    def on_send_requested(self, request: SendRequested) -> None:
        try:
            self.link.publish(request.body)
        except Exception as exc:  # the dashboard stays up whatever the bus does
            self._say(f"not sent: {request.what}: {exc}", error=True)
            return
        self._say(f"sent {request.what}")

    def on_note(self, note: Note) -> None:
        self._say(note.text, error=note.error)

    def _say(self, text: str, *, error: bool = False) -> None:
        with suppress(NoMatches):  # the panels are gone: the app is closing
            self.query_one(OperatorBar).set_status(text, error=error)
            self.query_one(LogPane).note(text, error=error)

    def _poll_mind(self) -> None:
        if self.auto_mind:
            self.link.publish(operator.mind_request(self.agent))

    def _poll_tree(self) -> None:
        self.link.publish(operator.tree_request())

    def action_mind(self) -> None:
        self.link.publish(operator.mind_request(self.agent))

    def action_auto_mind(self) -> None:
        self.auto_mind = not self.auto_mind
        self._say(f"mind snapshots every {self.mind_every:g} s" if self.auto_mind
                  else "mind snapshots only on m")

    def action_tree(self) -> None:
        self._poll_tree()

    def action_focus_percept(self) -> None:
        self.query_one("#percept", Input).focus()

    def action_focus_actions(self) -> None:
        self.query_one(ActionsTable).focus()
