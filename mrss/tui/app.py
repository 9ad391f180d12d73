"""MrssApp: the monitoring and debug dashboard of a running MRSS system (`mrss tui PROJECT`).

Panels: an alerts strip, the supervision tree, the robots, a map, the actions, the
reasoner's mind and a log; under them the operator's percept line. The app owns the
`BusLink` and the models: bus messages are drained from the link's inbox on the app's
thread (at most every `min_refresh` seconds, so a burst becomes one redraw), applied
to the models, and the panels that changed are redrawn. Widgets ask for bus messages
with `SendRequested`; sending (read-only refusals, questions, reports) is `steering.py`.

Safety: `q` only detaches this viewer (the system runs on); stopping the system is `X`
and asks first, naming what stops; so do cancel and teleop. `readonly` refuses every
control. A picture that never lies: on connecting (and after a proxy restart, and on
F5) the app asks for a full snapshot (tree, robots, open actions, mind, world model),
and a red banner says when the system has gone quiet or ended (`picture.py`). When
tables are redrawn is `redraws.py`.
"""

from __future__ import annotations

import time
from collections.abc import Callable
from contextlib import suppress
from typing import ClassVar

from textual.app import App, ComposeResult
from textual.binding import Binding, BindingType
from textual.containers import Horizontal
from textual.css.query import NoMatches
from textual.widgets import Footer, Header, Input, Static

from mrss.bus import BusEndpoints
from mrss.config.alerts import AlertRule
from mrss.config.map import MapConfig
from mrss.config.operator import GoalState, OperatorConfig
from mrss.messages import (
    ActionRequest,
    ActionStatus,
    DataReply,
    Envelope,
    MindSnapshot,
    Rejections,
    RobotData,
    RobotState,
    SupEvent,
)
from mrss.tui import gc_tuning, operator
from mrss.tui.buslink import BusLink
from mrss.tui.detail_keys import DetailKeys
from mrss.tui.events import READONLY_NOTICE, BusActivity
from mrss.tui.help import HelpScreen, current_keys
from mrss.tui.mission import MissionChannel
from mrss.tui.models.actions import ActionsModel
from mrss.tui.models.alerts import AlertsModel
from mrss.tui.models.goals import GoalsModel
from mrss.tui.models.liveness import Liveness
from mrss.tui.models.logfilter import LogEntry
from mrss.tui.models.map import MapModel
from mrss.tui.models.robots import RobotsModel
from mrss.tui.models.supervision import SupervisionModel
from mrss.tui.models.topics import TopicsModel
from mrss.tui.ops import OperatorTools
from mrss.tui.palette import MrssCommands
from mrss.tui.picture import TruthfulPicture
from mrss.tui.redraws import PANELS, TableRedraws
from mrss.tui.steering import Steering
from mrss.tui.vocabulary import Vocabulary
from mrss.tui.widgets.actions_table import ActionsTable
from mrss.tui.widgets.alerts_strip import AlertsStrip, alert_line
from mrss.tui.widgets.log_pane import LogPane, log_line
from mrss.tui.widgets.map_panel import MapPanel
from mrss.tui.widgets.mind_inspector import MindInspector
from mrss.tui.widgets.mission_panel import MissionPanel, goal_line
from mrss.tui.widgets.operator_bar import OperatorBar
from mrss.tui.widgets.robots_table import RobotsTable
from mrss.tui.widgets.supervision_table import SupervisionTable
from mrss.world.topics import WM_REQUEST_TOPIC


class MrssApp(TruthfulPicture, TableRedraws, Steering, DetailKeys, OperatorTools):
    """The dashboard; see the module docstring."""

    TITLE = "MRSS"
    COMMANDS = App.COMMANDS | {MrssCommands}
    CSS = """
    #top, #middle, #bottom { height: 1fr; }
    #actions { width: 3fr; }
    #mission { width: 2fr; }
    #actions, #mission { height: 1fr; }
    .panel { border: round $primary-darken-2; border-title-color: $accent; }
    .panel:focus-within { border: round $accent; }
    #supervision, #mind, #map { width: 1fr; }
    #robots, #log { width: 1fr; }
    #supervision, #robots { height: 100%; }  /* the row's height, not their rows' */
    #banner { display: none; height: 1; padding: 0 1; background: $error;
              color: $text; text-style: bold; }
    #banner.-shown { display: block; }
    #tabs { height: 1; display: none; }
    Header.-stale { background: $error; }
    """
    BINDINGS: ClassVar[list[BindingType]] = [
        Binding("m", "mind", "Mind now"),
        Binding("a", "auto_mind", "Auto mind on/off"),
        Binding("p", "focus_percept", "Percept"),
        Binding("escape", "focus_actions", "Actions", show=False),
        Binding("f5", "refresh_all", "Refresh all"),
        Binding("slash", "log_filter", "Filter log"),
        Binding("A", "ack_alerts", "Ack alerts"),
        Binding("H", "hold_all", "All hold"),
        Binding("question_mark,f1", "help", "Help"),
        Binding("X", "stop_system", "Stop system"),
        Binding("q", "close", "Detach"),
        Binding("ctrl+q", "close", "Detach", show=False, priority=True),
        Binding("M", "messages", "Messages"),  # ops.py; last: the footer keeps X and q
        Binding("L", "log_lines", "Log lines"),
        Binding("exclamation_mark", "alerts_list", "Alerts list"),
    ]

    def __init__(self, endpoints: BusEndpoints, *, project: str = "", agent: str = "",
                 mind_every: float = 1.0, tree_every: float = 2.0,
                 min_refresh: float = 0.5, readonly: bool = False,
                 stale_after: float = 5.0, world_every: float = 2.0,
                 operator_config: OperatorConfig | None = None,
                 mission: MissionChannel | None = None,
                 clock: Callable[[], float] = time.time, header_clock: bool = True,
                 restart_budget: tuple[int, float] | None = None,
                 vocabulary: Vocabulary | None = None,
                 alert_rules: tuple[AlertRule, ...] = (),
                 map_config: MapConfig | None = None,
                 quiet_gc: bool = False) -> None:
        super().__init__()
        self.quiet_gc = quiet_gc  # the process is the dashboard: tune its collector
        self.vocabulary = vocabulary or Vocabulary()  # the agent's predicates (warnings)
        self.restart_budget = restart_budget  # the root's (intensity, period), if known
        self.clock = clock  # wall-clock time of ages and uptimes (tests freeze it)
        self.header_clock = header_clock
        self.operator_config = operator_config or (mission.config if mission else
                                                   OperatorConfig())
        self.mission = mission
        self.goals = GoalsModel(self.operator_config.goals)
        self.holding = False
        self._system_stopping = False  # the root said it stops everything
        self.project = project
        self.agent = agent
        self.readonly = readonly
        self.link = BusLink(endpoints)
        self.supervision = SupervisionModel(root=project)
        self.robots = RobotsModel()
        self.actions = ActionsModel()
        self.liveness = Liveness(stale_after)
        self.map_model = MapModel(map_config)  # the project's [map] styles
        self.alerts = AlertsModel(rules=alert_rules)
        self.topics = TopicsModel()  # the Messages screen's (`M`): counted in each drain
        self.world_every = world_every
        self.world_asked = 0
        self.auto_mind = mind_every > 0
        self.mind_every = mind_every
        self.tree_every = tree_every
        self.min_refresh = min_refresh
        self.flushes = 0  # drains that found messages (tests check batching with it)
        self.snapshots_asked = 0
        self._welcomes = 0
        self._last_drain = 0.0
        self._drain_pending = False
        self._banner_shown: str | None = None
        self.table_every = 2 * min_refresh  # seconds: a table is redrawn at most this often
        self._drawn: dict[str, float] = {}  # table -> when it was last redrawn (monotonic)
        self._table_due: set[str] = set()  # tables with a redraw scheduled

    # -- layout -----------------------------------------------------------------------------
    def compose(self) -> ComposeResult:
        yield Header(show_clock=self.header_clock)
        yield Static("", id="banner")
        yield Static("", id="tabs")
        yield AlertsStrip(self.alerts, id="alerts")
        with Horizontal(id="top"):
            yield SupervisionTable(self.supervision, id="supervision")
            yield RobotsTable(self.robots, self.goals, id="robots")
            yield MapPanel(self.map_model, id="map")
        with Horizontal(id="middle"):
            yield ActionsTable(self.actions, id="actions")
            yield MissionPanel(self.goals, self.actions, id="mission")
        with Horizontal(id="bottom"):
            yield MindInspector(id="mind")
            yield LogPane(id="log")
        bar = OperatorBar(id="operator")
        bar.vocabulary = self.vocabulary
        yield bar
        yield Footer()

    def on_mount(self) -> None:
        titles = {"supervision": "Supervision (k kill, h hang, x crash: press twice)",
                  "robots": "Robots (t teleop, g map)",
                  "actions": "Actions (debug, around the agent: c cancel, s suspend, r resume)",
                  "mission": "Mission (n area, c cancel, +/- priority, H all hold)",
                  "mind": "Mind (m refresh, a auto)",
                  "log": "Log (/ filter, End follow)"}
        titles["map"] = "Map"
        for ident, title in titles.items():
            widget = self.query_one(f"#{ident}")
            widget.add_class("panel")
            widget.border_title = title
        if self.readonly:
            self.query_one("#percept", Input).disabled = True
            self.title = f"{self.TITLE} (read-only)"
        self._show_liveness()
        self.link.start(wake=lambda: self.post_message(BusActivity()))
        self.set_interval(1.0, self._tick)
        self.set_interval(0.25, self._watch_link)
        if self.mind_every > 0:
            self.set_interval(self.mind_every, self._poll_mind)
        if self.tree_every > 0:
            self.set_interval(self.tree_every, self._poll_tree)
        if self.world_every > 0:
            self.set_interval(self.world_every, self.ask_world)
        self.query_one(AlertsStrip).show_alerts()
        self.query_one("#actions").focus()
        if self.quiet_gc:
            self.call_after_refresh(gc_tuning.quiet_gc)  # once the screen is up

    def on_unmount(self) -> None:
        self.stop_recording()
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
            self.topics.count(envelopes)
            if any(env.src != self.link.src for env in envelopes):
                self.liveness.heard()  # whatever applying them does: the system spoke
            with suppress(NoMatches):  # the panels are gone: the app is closing
                self.apply(envelopes)

    def _timed_drain(self) -> None:
        self._drain_pending = False
        self._drain_bus()

    def apply(self, envelopes: list[Envelope]) -> None:
        """Apply a batch of bus messages to the models, then redraw what changed."""
        dirty: set[str] = set()
        lines: list[LogEntry] = []
        mind: Envelope | None = None
        for env in envelopes:
            if env.replayed:  # `mrss replay`: not the system now (the topic browser marks it)
                continue
            body = env.body
            for alert in self.alerts.apply(env):
                dirty.add("alerts")
                lines.append(alert_line(alert, env.ts))
            if isinstance(body, ActionStatus):
                self.actions.apply_status(body, env.ts, env.src)
                dirty.add("actions")
                if self.map_model.apply_status(body):
                    dirty.add("map")
            elif isinstance(body, ActionRequest):
                self.actions.apply_request(body, env.ts, env.src)
                dirty.add("actions")
            elif isinstance(body, RobotState):
                self.robots.apply_state(body)
                dirty.add("robots")
            elif isinstance(body, RobotData):
                self.robots.apply_data(body, env.ts)
                dirty.add("robots")
                if self.map_model.apply_data(body):
                    dirty.add("map")
            elif (isinstance(body, DataReply)
                  and body.request_id.startswith(operator.WORLD_REQUEST_PREFIX)):
                self._world_reply(body)
                dirty.add("map")
            elif isinstance(body, SupEvent):
                self.supervision.apply_event(body, env.src, env.ts)
                self._system_end(body, env.src)
                dirty.add("supervision")
            elif isinstance(body, Rejections):
                self.supervision.apply_rejections(body)
                dirty.update(("supervision", "alerts"))  # the counts, the alert's text
            elif isinstance(body, MindSnapshot) and body.agent in ("", self.agent or body.agent):
                mind = env
            line = log_line(env)
            if line is not None:
                lines.append(line)
        now = self.clock()
        if mind is not None and isinstance(mind.body, MindSnapshot) and self.goals.declared \
                and self.goals.apply_beliefs(mind.body.beliefs, mind.ts, self.actions):
            dirty |= {"mission", "robots"}
            for view in self.goals.take_ended():
                lines.append(goal_line(view))
                if view.state is GoalState.FAILED:
                    lines.append(alert_line(self.alerts.goal_failed(view.goal, view.robot,
                                                                    view.since), view.since))
                    dirty.add("alerts")
        if "actions" in dirty:
            dirty.add("mission")  # its goals' actions
        for table in PANELS:
            if table in dirty:
                self._table_changed(table, now)
        if mind is not None and isinstance(mind.body, MindSnapshot):
            self.query_one(MindInspector).show_snapshot(mind.body, mind.ts, mind.inc)
        if "alerts" in dirty:
            self.query_one(AlertsStrip).show_alerts()
        if lines:
            self.query_one(LogPane).add(lines)

    def _world_reply(self, reply: DataReply) -> None:
        if not reply.ok:
            self.map_model.world_error = reply.error
        elif not self.map_model.apply_world(reply.result):
            self.map_model.world_error = "wm.list answered something other than a list"

    def action_close(self) -> None:
        """`q`: detach this viewer; the system keeps running."""
        self.exit()

    def _poll_mind(self) -> None:
        if self.auto_mind:
            with suppress(Exception):
                self.link.publish(operator.mind_request(self.agent))

    def ask_world(self) -> None:
        """Ask the world model for its objects (the answer comes as a `DataReply`)."""
        self.world_asked += 1
        with suppress(Exception):  # not connected yet: the next ask will do
            self.link.publish(operator.world_request(self.world_asked), WM_REQUEST_TOPIC)

    # -- map, alerts, help, palette ----------------------------------------------------------
    def map_follow(self, robot: str | None) -> bool:
        """Centre the map on `robot` and keep it there (None: stop); False if the map
        has no position for it."""
        if robot is not None and robot not in self.map_model.robots:
            return False
        self.query_one(MapPanel).follow(robot)
        return True

    def map_fit(self) -> None:
        self.query_one(MapPanel).action_fit()

    def action_ack_alerts(self) -> None:
        count = self.alerts.acknowledge()
        self.query_one(AlertsStrip).show_alerts()
        self._say(f"acknowledged {count} alert{'s' if count != 1 else ''}" if count
                  else "no new alerts")

    def action_help(self) -> None:
        focused = self.focused
        name = "nothing" if focused is None else (focused.id or type(focused).__name__)
        self.push_screen(HelpScreen(current_keys(self), name))

    def _poll_tree(self) -> None:
        with suppress(Exception):
            self.link.publish(operator.tree_request())

    def action_mind(self) -> None:
        self.link.publish(operator.mind_request(self.agent))

    def action_auto_mind(self) -> None:
        self.auto_mind = not self.auto_mind
        self._say(f"mind snapshots every {self.mind_every:g} s" if self.auto_mind
                  else "mind snapshots only on m")

    def action_refresh_all(self) -> None:
        self.ask_snapshot()
        self._say("asked for a full snapshot (tree, robots, actions, mind, world model)")

    def action_focus_percept(self) -> None:
        if self.readonly:
            self._say(f"percept line: {READONLY_NOTICE}", error=True)
            return
        self.query_one("#percept", Input).focus()

    def action_focus_actions(self) -> None:
        self.query_one(ActionsTable).focus()

    def action_log_filter(self) -> None:
        self.query_one(LogPane).open_filter()
