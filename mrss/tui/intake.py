"""How the bus's messages reach the dashboard's models: when, and what each changes.

When: on `BusActivity` (the link's inbox went from empty to not) the whole inbox is
drained on the app's thread, but drains are at least `min_refresh` seconds apart, so a
burst of a thousand statuses is one batch (and one redraw), not a thousand. What: each
message of a batch is applied to its model (actions, robots, the map, supervision,
alerts, the world model's answer), the newest mind snapshot of the agent watched to the
goals; the batch's `Changes` say which panels changed, the log lines it makes and the
mind snapshot to show, and the app shows them.
"""

from __future__ import annotations

import time
from collections.abc import Callable
from dataclasses import dataclass, field
from typing import NamedTuple

from textual.app import App

from mrss.config.operator import GoalState
from mrss.messages import (
    ActionRequest,
    ActionStatus,
    AnswerReply,
    DataReply,
    Envelope,
    MindSnapshot,
    OperatorQuestion,
    Rejections,
    RobotData,
    RobotState,
    StandDownState,
    SupEvent,
    TaskAllocation,
)
from mrss.tui import operator
from mrss.tui.buslink import BusLink
from mrss.tui.models.actions import ActionsModel
from mrss.tui.models.alerts import AlertsModel
from mrss.tui.models.goals import GoalsModel
from mrss.tui.models.liveness import Liveness
from mrss.tui.models.logfilter import LogEntry
from mrss.tui.models.map import MapModel
from mrss.tui.models.questions import QuestionsModel
from mrss.tui.models.robots import RobotsModel
from mrss.tui.models.supervision import SupervisionModel
from mrss.tui.models.topics import TopicsModel
from mrss.tui.stand_down import stand_down_line
from mrss.tui.widgets.alerts_strip import alert_line
from mrss.tui.widgets.log_pane import log_line
from mrss.tui.widgets.mission_panel import goal_line


class Mind(NamedTuple):
    """A mind snapshot as it came: the inspector shows its time and incarnation."""

    snapshot: MindSnapshot
    ts: float
    inc: int


@dataclass
class Changes:
    """What a batch changed: the panels to redraw (`redraws.SCHEDULED`, and "alerts" for
    the strip), the log's new lines, the newest mind snapshot of the agent watched."""

    panels: set[str] = field(default_factory=set)
    lines: list[LogEntry] = field(default_factory=list)
    mind: Mind | None = None
    replies: list[AnswerReply] = field(default_factory=list)  # to this dashboard's answers


@dataclass(frozen=True)
class Models:
    """The app's models a batch is applied to."""

    actions: ActionsModel
    robots: RobotsModel
    supervision: SupervisionModel
    goals: GoalsModel
    alerts: AlertsModel
    map_model: MapModel
    topics: TopicsModel
    liveness: Liveness
    questions: QuestionsModel


class BusIntake:
    """Drains `link` into `models`; `deliver` gets each non-empty batch (the app applies
    and shows it), `system_event` each supervision event (the banner's `Picture`)."""

    def __init__(self, app: App[None], link: BusLink, models: Models, *, agent: str,
                 min_refresh: float, deliver: Callable[[list[Envelope]], None],
                 system_event: Callable[[SupEvent, str], None]) -> None:
        self.app = app
        self.link = link
        self.models = models
        self.agent = agent  # "" : whichever agent answers
        self.min_refresh = min_refresh
        self.deliver = deliver
        self.system_event = system_event
        self.flushes = 0  # drains that found messages (tests check batching with it)
        self._last_drain = 0.0
        self._drain_pending = False

    # -- when -------------------------------------------------------------------------------
    @property
    def pending(self) -> bool:
        """Whether a drain is set for when `min_refresh` is up (messages are waiting)."""
        return self._drain_pending

    def drain(self) -> None:
        """Take the inbox now, or (drained less than `min_refresh` ago) when that is up."""
        wait = self._last_drain + self.min_refresh - time.monotonic()
        if wait > 0:
            if not self._drain_pending:
                self._drain_pending = True
                self.app.set_timer(wait, self._timed_drain)
            return
        self._last_drain = time.monotonic()
        envelopes = self.link.drain()
        if envelopes:
            self.flushes += 1
            self.models.topics.count(envelopes)
            if any(env.src != self.link.src for env in envelopes):
                self.models.liveness.heard()  # whatever applying them does: the system spoke
            self.deliver(envelopes)

    def _timed_drain(self) -> None:
        self._drain_pending = False
        self.drain()

    # -- what -------------------------------------------------------------------------------
    def take(self, envelopes: list[Envelope]) -> Changes:
        """Apply a batch of bus messages to the models; what changed."""
        m = self.models
        changes = Changes()
        dirty, lines = changes.panels, changes.lines
        for env in envelopes:
            if env.replayed:  # `mrss replay`: not the system now (the topic browser marks it)
                continue
            body = env.body
            for alert in m.alerts.apply(env):
                dirty.add("alerts")
                lines.append(alert_line(alert, env.ts))
            if isinstance(body, ActionStatus):
                m.actions.apply_status(body, env.ts, env.src)
                dirty.add("actions")
                if m.map_model.apply_status(body):
                    dirty.add("map")
            elif isinstance(body, ActionRequest):
                m.actions.apply_request(body, env.ts, env.src)
                dirty.add("actions")
            elif isinstance(body, TaskAllocation):
                self._allocation(body, env.ts, changes)
            elif isinstance(body, RobotState):
                m.robots.apply_state(body)
                dirty.add("robots")
            elif isinstance(body, RobotData):
                m.robots.apply_data(body, env.ts)
                dirty.add("robots")
                if m.map_model.apply_data(body):
                    dirty.add("map")
            elif (isinstance(body, DataReply)
                  and body.request_id.startswith(operator.WORLD_REQUEST_PREFIX)):
                self._world_reply(body)
                dirty.add("map")
            elif isinstance(body, SupEvent):
                m.supervision.apply_event(body, env.src, env.ts)
                self.system_event(body, env.src)
                dirty.add("supervision")
            elif isinstance(body, Rejections):
                m.supervision.apply_rejections(body)
                dirty.update(("supervision", "alerts"))  # the counts, the alert's text
            elif isinstance(body, StandDownState):
                if m.map_model.apply_stand_down(body):
                    dirty.add("map")
                lines.append(stand_down_line(body, env.ts))
            elif isinstance(body, OperatorQuestion):
                m.questions.apply(body)
            elif isinstance(body, AnswerReply):
                changes.replies.append(body)
            elif isinstance(body, MindSnapshot) and body.agent in ("", self.agent or body.agent):
                changes.mind = Mind(body, env.ts, env.inc)
            line = log_line(env)
            if line is not None:
                lines.append(line)
        mind = changes.mind
        if mind is not None and m.goals.declared \
                and m.goals.apply_beliefs(mind.snapshot.beliefs, mind.ts, m.actions):
            dirty |= {"mission", "robots"}
            for view in m.goals.take_ended():
                why = m.goals.reason(view, m.actions)
                lines.append(goal_line(view, why))
                if view.state is GoalState.FAILED:
                    lines.append(alert_line(m.alerts.goal_failed(view.goal, view.robot,
                                                                 view.since, why), view.since))
                    dirty.add("alerts")
        if "actions" in dirty:
            dirty.add("mission")  # its goals' actions
        return changes

    def _allocation(self, body: TaskAllocation, ts: float, changes: Changes) -> None:
        """A task's award or wait: its row's holder and reason; a hand-over from a lost
        robot is an alert (and so a log line)."""
        m = self.models
        change = m.actions.tasks.apply(body, ts)
        changes.panels.update(("actions", "robots"))
        if change is None:
            return
        lost = m.robots.robots.get(change.lost_from)
        alert = m.alerts.reassigned(change.subject, change.lost_from, change.robot, ts,
                                    lost.reason if lost is not None else "")
        changes.panels.add("alerts")
        changes.lines.append(alert_line(alert, ts))

    def _world_reply(self, reply: DataReply) -> None:
        if not reply.ok:
            self.models.map_model.world_error = reply.error
        elif not self.models.map_model.apply_world(reply.result):
            self.models.map_model.world_error = "wm.list answered something other than a list"
