"""MrssApp: the monitoring and debug dashboard of a running MRSS system (`mrss tui PROJECT`).

Panels: an alerts strip, the supervision tree, the robots, a map, the actions, the
mission's goals, the reasoner's mind and a log; under them the operator's percept line.
The app owns the `BusLink`, the models (`models/`) and the screen; each idea of the
dashboard is an object of its own that the app creates and holds, and hands its keys
and messages to:

- `BusIntake` (`intake.py`): when the bus is drained, and what its messages change;
- `Redraws` (`redraws.py`): when the tables and the map are redrawn;
- `Picture` (`picture.py`): the snapshots and polls asked for, and the banner;
- `Steering` (`steering.py`): what the operator sends: refusals, questions, reports;
- `RowDetails` (`detail_keys.py`): the detail screen Enter opens on a row;
- `OperatorTools` (`ops.py`): the Messages, log-line and alerts screens, recording;
- `PanelLayout` (`layout.py`): the compact mode and the panel keys;
- `IncidentFeed` (`incident.py`): the run's incident record, in the log on attach;
- `AnswerDesk` (`answers.py`): the agent's questions (`O`) and the operator's answers;
- `log_in_first` (`login.py`): with users configured, the login before anything else.
Their bindings and `action_*` methods stay here, where Textual looks for them.

One idea in one module: the app is the hub Textual reads (bindings, message handlers,
actions), each a line or two handing over to the idea that does the work; cutting it
would scatter the keys a reader looks for in one place.
"""

from __future__ import annotations

import time
from collections.abc import Callable
from contextlib import suppress
from typing import ClassVar

from textual import events
from textual.app import App, ComposeResult
from textual.binding import Binding, BindingType
from textual.containers import Horizontal
from textual.css.query import NoMatches
from textual.widgets import Footer, Input, Static

from mrss.bus import BusEndpoints
from mrss.config.alerts import AlertRule
from mrss.config.map import MapConfig
from mrss.config.operator import OperatorConfig
from mrss.messages import Envelope, Percept
from mrss.tui import gc_tuning
from mrss.tui.answers import AnswerDesk
from mrss.tui.buslink import BusLink
from mrss.tui.detail_keys import RowDetails
from mrss.tui.events import READONLY_NOTICE, BusActivity, MissionRequested, Note, SendRequested
from mrss.tui.help import HelpScreen, current_keys
from mrss.tui.incident import IncidentFeed
from mrss.tui.intake import BusIntake, Models
from mrss.tui.layout import LAYOUT_BINDINGS, PanelLayout, is_compact
from mrss.tui.login import Login, log_in_first
from mrss.tui.mission import MissionChannel
from mrss.tui.models.actions import ActionsModel
from mrss.tui.models.alerts import AlertsModel
from mrss.tui.models.goals import GoalsModel
from mrss.tui.models.liveness import Liveness
from mrss.tui.models.map import MapModel
from mrss.tui.models.questions import QuestionsModel
from mrss.tui.models.robots import RobotsModel
from mrss.tui.models.supervision import SupervisionModel
from mrss.tui.models.topics import TopicsModel
from mrss.tui.ops import OperatorTools
from mrss.tui.palette import MrssCommands
from mrss.tui.picture import Picture
from mrss.tui.polls import DEFAULT_POLLS, Polls
from mrss.tui.recorder import DashboardRecording
from mrss.tui.redraws import Redraws
from mrss.tui.steering import Steering
from mrss.tui.vocabulary import Vocabulary
from mrss.tui.widgets.actions_table import ActionsTable
from mrss.tui.widgets.alerts_strip import AlertsStrip
from mrss.tui.widgets.log_pane import LogPane
from mrss.tui.widgets.map_panel import MapPanel
from mrss.tui.widgets.mind_inspector import MindInspector
from mrss.tui.widgets.mission_panel import MissionPanel
from mrss.tui.widgets.operator_bar import OperatorBar
from mrss.tui.widgets.robots_table import RobotsTable
from mrss.tui.widgets.strip_table import StripTable
from mrss.tui.widgets.supervision_table import SupervisionTable
from mrss.tui.widgets.ticked_header import TickedHeader

#: Seconds between two drains of the bus (at least): one frame a second at a steady rate.
MIN_REFRESH = 1.0
TICK_EVERY = 1.0  # the tick: ages, uptimes, the clock
TICK_DUE = 0.5 * TICK_EVERY  # a drain this long after the last tick runs the tick too


class MrssApp(App[None]):
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
        *LAYOUT_BINDINGS,  # 1..7, z: layout.py
        Binding("m", "mind", "Mind now"),
        Binding("a", "auto_mind", "Auto mind on/off"),
        Binding("p", "focus_percept", "Percept"),
        Binding("escape", "focus_actions", "Actions", show=False),
        Binding("f5", "refresh_all", "Refresh all"),
        Binding("slash", "log_filter", "Filter log"),
        Binding("A", "ack_alerts", "Ack alerts"),
        Binding("H", "hold_all", "All hold"),
        Binding("U", "lift_stand_downs", "Lift stand-downs", show=False),
        Binding("question_mark,f1", "help", "Help"),
        Binding("X", "stop_system", "Stop system"),
        Binding("q", "close", "Detach"),
        Binding("ctrl+q", "close", "Detach", show=False, priority=True),
        Binding("M", "messages", "Messages"),  # ops.py; last: the footer keeps X and q
        Binding("L", "log_lines", "Log lines"),
        Binding("exclamation_mark", "alerts_list", "Alerts list"),
        Binding("O", "questions", "Answer the agent"),
    ]

    def __init__(self, endpoints: BusEndpoints, *, project: str = "", agent: str = "",
                 mind_every: float = DEFAULT_POLLS.mind_every,
                 tree_every: float = DEFAULT_POLLS.tree_every,
                 min_refresh: float = MIN_REFRESH, readonly: bool = False,
                 stale_after: float = DEFAULT_POLLS.stale_after,
                 world_every: float = DEFAULT_POLLS.world_every,
                 operator_config: OperatorConfig | None = None,
                 mission: MissionChannel | None = None,
                 clock: Callable[[], float] = time.time, header_clock: bool = True,
                 restart_budget: tuple[int, float] | None = None,
                 vocabulary: Vocabulary | None = None,
                 alert_rules: tuple[AlertRule, ...] = (),
                 map_config: MapConfig | None = None,
                 quiet_gc: bool = False, login: Login | None = None,
                 link: BusLink | None = None) -> None:
        super().__init__()
        self.login = login  # users configured: nothing shown or sent before a login
        self.quiet_gc = quiet_gc  # the process is the dashboard: tune its collector
        self.vocabulary = vocabulary or Vocabulary()  # the agent's predicates (warnings)
        self.clock = clock  # wall-clock time of ages and uptimes (tests freeze it)
        self.header_clock = header_clock
        self.operator_config = operator_config or (mission.config if mission else
                                                   OperatorConfig())
        self.mission = mission
        self.project = project
        self.readonly = readonly
        self.link = link or BusLink(endpoints)  # a replay's link reads a recording
        self.goals = GoalsModel(self.operator_config.goals)  # the models: plain Python
        self.supervision = SupervisionModel(root=project)
        self.robots = RobotsModel()
        self.actions = ActionsModel()
        self.liveness = Liveness(stale_after)
        self.map_model = MapModel(map_config)  # the project's [map] styles
        self.alerts = AlertsModel(rules=alert_rules)
        self.topics = TopicsModel()  # the Messages screen's (`M`): counted in each drain
        self.questions = QuestionsModel()  # the agent's questions to the operator
        self.incident = IncidentFeed.for_endpoints(endpoints)  # the run's record, on attach
        # the dashboard's ideas, each with its own state (above: the models)
        self.picture = Picture(self, self.link, liveness=self.liveness,
                               supervision=self.supervision, actions=self.actions,
                               project=project, agent=agent,
                               polls=Polls(mind_every, tree_every, world_every, stale_after),
                               on_end=self._system_ended)
        self.intake = BusIntake(
            self, self.link, Models(self.actions, self.robots, self.supervision, self.goals,
                                    self.alerts, self.map_model, self.topics, self.liveness,
                                    self.questions),
            agent=agent, min_refresh=min_refresh, deliver=self._deliver,
            system_event=self.picture.system_event)
        self.redraws = Redraws(self, table_every=max(TICK_EVERY, min_refresh), clock=clock)
        self._ticking = False  # the second's tick has started (the bus is watched)
        self._ticked = 0.0  # when the last tick ran (monotonic)
        self.steering = Steering(self, self.link, self.say, readonly=readonly,
                                 project=project, mission=mission,
                                 supervision=self.supervision, robots=self.robots,
                                 actions=self.actions, goals=self.goals)
        self.row_details = RowDetails(self, self.say, actions=self.actions,
                                      goals=self.goals, robots=self.robots,
                                      supervision=self.supervision,
                                      restart_budget=restart_budget, clock=clock)
        self.tools = OperatorTools(self, self.say, readonly=readonly, endpoints=endpoints,
                                   topics=self.topics, alerts=self.alerts, mission=mission,
                                   open_area_form=self.steering.open_area_form)
        self.panel_layout = PanelLayout(self)
        self.answers = AnswerDesk(self, self.link, self.say, self.questions,
                                  readonly=readonly)

    # -- what tests and the palette read -----------------------------------------------------
    @property
    def auto_mind(self) -> bool:
        """Whether the mind is polled (`a` toggles it)."""
        return self.picture.auto_mind

    @auto_mind.setter
    def auto_mind(self, on: bool) -> None:
        self.picture.auto_mind = on

    @property
    def snapshots_asked(self) -> int:
        return self.picture.snapshots_asked

    @property
    def flushes(self) -> int:
        return self.intake.flushes

    @property
    def table_every(self) -> float:
        return self.redraws.table_every

    @property
    def recording(self) -> DashboardRecording | None:
        return self.tools.recording

    def banner_text(self) -> str:
        """What the red banner says ("" when the picture is current)."""
        return self.picture.banner_text()

    # -- layout -----------------------------------------------------------------------------
    def compose(self) -> ComposeResult:
        yield TickedHeader(show_clock=self.header_clock)
        yield Static("", id="banner")
        yield Static("", id="tabs")
        yield AlertsStrip(self.alerts, id="alerts")
        with Horizontal(id="top"):
            yield SupervisionTable(self.supervision, id="supervision")
            yield RobotsTable(self.robots, self.goals, self.actions, id="robots")
            yield MapPanel(self.map_model, id="map")
        with Horizontal(id="middle"):
            yield ActionsTable(self.actions, robots=self.robots, id="actions")
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
                  "robots": "Robots (t teleop, g map)", "map": "Map",
                  "actions": "Actions (debug, around the agent: c cancel, s suspend, r resume)",
                  "mission": "Mission (n new, c cancel, +/- priority, H all hold)",
                  "mind": "Mind (m refresh, a auto)", "log": "Log (/ filter, End follow)"}
        for ident, title in titles.items():
            widget = self.query_one(f"#{ident}")
            widget.add_class("panel")
            widget.border_title = title
        if self.readonly:
            self.query_one("#percept", Input).disabled = True
            self.title = f"{self.TITLE} (read-only)"
        log_in_first(self, self._watch)  # login.py: users configured, a login first

    def _watch(self) -> None:
        """Connect to the bus and show the system (after the login, if any)."""
        self.picture.show()
        self.query_one(LogPane).add(self.incident.attach_lines())
        self.link.start(wake=lambda: self.post_message(BusActivity()))
        self._ticking = True
        self.set_interval(TICK_EVERY, self._tick_due)
        self.picture.start()
        self.query_one(AlertsStrip).show_alerts()
        self.query_one("#actions").focus()
        if self.quiet_gc:
            self.call_after_refresh(gc_tuning.quiet_gc)  # once the screen is up

    def on_unmount(self) -> None:
        self.tools.stop_recording()
        self.link.close()

    # -- bus traffic ------------------------------------------------------------------------
    def on_bus_activity(self, _: BusActivity) -> None:
        self.intake.drain()

    def _deliver(self, envelopes: list[Envelope]) -> None:
        with suppress(NoMatches):  # the panels are gone: the app is closing
            self.apply(envelopes)

    def apply(self, envelopes: list[Envelope]) -> None:
        """Apply a batch of bus messages to the models, then redraw what changed."""
        changes = self.intake.take(envelopes)
        self.redraws.changed(changes.panels)
        if changes.mind is not None:
            snapshot, ts, inc = changes.mind
            self.query_one(MindInspector).show_snapshot(snapshot, ts, inc)
        if "alerts" in changes.panels:
            self.query_one(AlertsStrip).show_alerts()
        if changes.lines:
            self.query_one(LogPane).add(changes.lines)
        for reply in changes.replies:
            self.answers.on_reply(reply)
        if "mission" in changes.panels and self.steering.awaiting:
            self.steering.follow_answers()
        if self._ticking and time.monotonic() - self._ticked >= TICK_DUE:
            self.tick()  # due anyway: in this drain's frame, not one of its own

    def _tick_due(self) -> None:
        """The second's timer: tick, unless a drain is pending (it comes within
        `min_refresh` and ticks in its own frame: one frame, not two)."""
        if not self.intake.pending:
            self.tick()

    def tick(self) -> None:
        """Once a second: uptimes, ages and the connection state move on. Run by the
        drains while messages flow (at most every `TICK_DUE`), else by its timer."""
        self._ticked = time.monotonic()
        with suppress(NoMatches):
            self.query_one(TickedHeader).tick()
        self.incident.poll()  # the record's rows since: `incident.entries` is all of it
        self.answers.resend()
        with suppress(NoMatches):  # the panels are gone: the app is closing
            self.redraws.tick()
            self.picture.show()

    def _system_ended(self) -> None:
        """The system ended: its robots are unknown, its components stopped."""
        self.robots.system_stopped()
        self.supervision.system_stopped()
        with suppress(NoMatches):
            self.redraws.changed(("robots", "supervision"))

    def say(self, text: str, *, error: bool = False) -> None:
        """Tell the operator: the status line and the log."""
        with suppress(NoMatches):  # the panels are gone: the app is closing
            self.query_one(OperatorBar).set_status(text, error=error)
            self.query_one(LogPane).note(text, error=error)

    # -- Textual's messages, handed over ----------------------------------------------------
    def on_send_requested(self, request: SendRequested) -> None:
        self.steering.send_requested(request)

    def on_mission_requested(self, request: MissionRequested) -> None:
        self.steering.mission_requested(request)

    def on_note(self, note: Note) -> None:
        self.say(note.text, error=note.error)

    def on_map_panel_shape_drawn(self, event: MapPanel.ShapeDrawn) -> None:
        self.steering.open_command_with(event.kind, event.text)

    def on_strip_table_row_selected(self, event: StripTable.RowSelected) -> None:
        self.row_details.open_row(event)

    def on_resize(self, event: events.Resize) -> None:
        self.panel_layout.set_compact(is_compact(event.size.width, event.size.height))

    def on_descendant_focus(self, event: events.DescendantFocus) -> None:
        self.panel_layout.focus_moved(event.widget)

    # -- keys -------------------------------------------------------------------------------
    def action_close(self) -> None:
        """`q`: detach this viewer; the system keeps running."""
        self.exit()

    def action_mind(self) -> None:
        self.picture.ask_mind()

    def action_auto_mind(self) -> None:
        self.auto_mind = not self.auto_mind
        self.say(f"mind snapshots every {self.picture.polls.mind_every:g} s" if self.auto_mind
                 else "mind snapshots only on m")

    def action_refresh_all(self) -> None:
        self.picture.ask_snapshot()
        self.say("asked for a full snapshot (tree, robots, actions, mind, world model)")

    def action_focus_percept(self) -> None:
        if self.readonly:
            self.say(f"percept line: {READONLY_NOTICE}", error=True)
            return
        self.query_one("#percept", Input).focus()

    def action_focus_actions(self) -> None:
        self.query_one(ActionsTable).focus()

    def action_log_filter(self) -> None:
        self.query_one(LogPane).open_filter()

    def action_ack_alerts(self) -> None:
        count = self.alerts.acknowledge()
        self.query_one(AlertsStrip).show_alerts()
        self.say(f"acknowledged {count} alert{'s' if count != 1 else ''}" if count
                 else "no new alerts")

    def action_help(self) -> None:
        focused = self.focused
        name = "nothing" if focused is None else (focused.id or type(focused).__name__)
        self.push_screen(HelpScreen(current_keys(self), name))

    def action_hold_all(self) -> None:
        self.steering.hold_all()

    def action_lift_stand_downs(self) -> None:
        self.steering.lift_stand_downs(self.map_model.stand_downs)

    def action_stop_system(self) -> None:
        self.steering.stop_system()

    def action_messages(self) -> None:
        self.tools.messages()

    def action_log_lines(self) -> None:
        self.tools.log_lines()

    def action_alerts_list(self) -> None:
        self.tools.alerts_list()

    def action_questions(self) -> None:
        self.answers.open()

    def action_show_panel(self, ident: str) -> None:
        self.panel_layout.show_panel(ident)

    def action_maximise(self) -> None:
        self.panel_layout.maximise()

    # -- what the widgets and the palette call ----------------------------------------------
    def map_follow(self, robot: str | None) -> bool:
        """Centre the map on `robot` and keep it there (None: stop); False if the map
        has no position for it."""
        if robot is not None and robot not in self.map_model.robots:
            return False
        self.query_one(MapPanel).follow(robot)
        return True

    def map_fit(self) -> None:
        self.query_one(MapPanel).action_fit()

    def open_area_form(self) -> None:
        self.steering.open_area_form()

    def open_actions_of(self, robot: str) -> list[str]:
        return self.steering.open_actions_of(robot)

    def send_percept(self, percept: Percept) -> None:
        self.steering.send_percept(percept)

    def add_goal(self) -> None:
        self.tools.add_goal()

    def toggle_recording(self) -> None:
        self.tools.toggle_recording()
