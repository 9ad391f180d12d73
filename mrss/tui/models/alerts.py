"""The operator's alerts: rules over incoming bus messages, acknowledgement, history.

Conditions (battery low, link down, robot unavailable, a robot the geofence found
stopped inside a no-go zone, or trapped there) are raised when they begin and
resolved when they end; one alert per robot and kind, however often the condition is
repeated; a component refusing input (its `Rejections` reports) is one such
condition, its text the latest counts, and so is a component whose restart budget
(as its supervisor reports it in the tree) leaves at most one more restart. Events
(hotspot found, component restarted, hung, quarantined, gave up; a mission goal
failed for good, as the goals model reads it from the agent; a goal the agent gave up,
as the reasoner reports it, `GoalGaveUp`: its agent, reason and last cause; a task
addressed to a role handed from a lost robot to another, as the RCL's allocator reports
it: `reassigned`) raise one alert per subject, counted when they recur: a recurrence
of an acknowledged alert raises it again. Acknowledging clears the highlight; every
alert stays in the history; one alert can be acknowledged by its key
(`acknowledge_one`). A project's own rules (`[[alerts]]`, `mrss.config.alerts`) are
conditions on a telemetry field, named by the rule. Pure Python: no Textual.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from enum import StrEnum
from typing import Any

from mrss.actors.datalayer.geofence import EXIT, TRAPPED
from mrss.config.alerts import AlertRule, Severity
from mrss.messages import (
    Envelope,
    GoalGaveUp,
    LinkState,
    OperatorQuestion,
    Percept,
    QuestionState,
    Rejections,
    RobotData,
    RobotState,
    SupEvent,
    SupEventKind,
)
from mrss.supervision.nodes import NODE_DOWN, NODE_UP

BATTERY_LOW = 20.0  # percent: below it a robot's battery is low
HISTORY_LIMIT = 500  # alerts kept (oldest dropped)


class AlertKind(StrEnum):
    BATTERY_LOW = "battery low"
    LINK_DOWN = "link down"
    UNAVAILABLE = "unavailable"
    QUARANTINED = "quarantined"
    HOTSPOT = "hotspot"
    RESTARTED = "restarted"
    HUNG = "hung"
    GAVE_UP = "gave up"
    NODE_DOWN = "node down"  # a peer node lost (several hosts)
    REFUSED = "refused input"
    BUDGET = "restart budget nearly used"
    GOAL_FAILED = "goal failed"  # for good: the agent gave it up (its retries included)
    GOAL_GAVE_UP = "goal given up"  # the reasoner's report (GoalGaveUp): reason, last cause
    RULE = "rule"  # a project's own rule (`[[alerts]]`): the alert carries the rule's name
    NO_GO = "inside a no-go zone"  # the geofence found the robot stopped there: leaving
    TRAPPED = "trapped in a no-go zone"  # ... and every way out crosses another zone
    QUESTION = "question"  # the agent waits for the operator's answer (`.ask_operator`)
    REASSIGNED = "task reassigned"  # a lost robot's task went to another (models/tasks.py)


CONDITIONS = (AlertKind.BATTERY_LOW, AlertKind.LINK_DOWN, AlertKind.UNAVAILABLE,
              AlertKind.NODE_DOWN, AlertKind.REFUSED, AlertKind.BUDGET, AlertKind.NO_GO,
              AlertKind.TRAPPED, AlertKind.QUESTION)
SEVERE = (AlertKind.QUESTION, AlertKind.GOAL_FAILED, AlertKind.GOAL_GAVE_UP, AlertKind.GAVE_UP,
          AlertKind.LINK_DOWN, AlertKind.HUNG, AlertKind.QUARANTINED, AlertKind.NODE_DOWN,
          AlertKind.TRAPPED)
#: The geofence's percepts (mrss.actors.datalayer.geofence) and the alert each raises.
GEOFENCE = {EXIT: AlertKind.NO_GO, TRAPPED: AlertKind.TRAPPED}


@dataclass
class Alert:
    """One alert: what, about whom, the latest detail, when, how often."""

    kind: AlertKind
    subject: str
    text: str
    ts: float
    count: int = 1
    acked: bool = False
    resolved: bool = False
    name: str = ""  # a project rule's name ("" for the built-in kinds)
    severe_rule: bool = False  # a project rule of severity "severe"

    @property
    def label(self) -> str:
        return self.name or self.kind.value

    @property
    def key(self) -> tuple[str, str]:
        return self.label, self.subject

    @property
    def severe(self) -> bool:
        return self.kind in SEVERE or self.severe_rule

    def line(self) -> str:
        times = f" ×{self.count}" if self.count > 1 else ""
        ended = " (over)" if self.resolved else ""
        return f"{self.label}: {self.subject}{times} {self.text}{ended}".rstrip()


def battery_percent(data: dict[str, Any]) -> float | None:
    """The battery level in a telemetry record (`battery` link record or flat map)."""
    kind = data.get("type")
    value: Any = None
    if kind == "battery":
        value = data.get("remaining")
    elif not kind:
        value = data.get("battery")
        if isinstance(value, dict):
            value = value.get("remaining")
    if isinstance(value, (int, float)) and not isinstance(value, bool) and math.isfinite(value):
        return float(value)
    return None


def nearly_used(budget: Any) -> str | None:
    """`4 of 5 in 30 s` when a reported `[used, limit, period]` leaves at most one restart,
    "" when it leaves more, None when it is no budget."""
    if not isinstance(budget, list) or len(budget) != 3 or not all(
            isinstance(v, (int, float)) and not isinstance(v, bool) for v in budget):
        return None
    used, limit, period = budget
    if used >= max(1, limit - 1):
        return f"{used:g} of {limit:g} in {period:g} s"
    return ""


def geofence_args(literal: str) -> tuple[AlertKind, str, str] | None:
    """(kind, robot, text) of a geofence percept's literal, None for any other."""
    functor, _, rest = literal.partition("(")
    kind = GEOFENCE.get(functor)
    if kind is None or not rest.endswith(")"):
        return None
    args = [a.strip().strip('"') for a in rest[:-1].split(",")]
    if kind is AlertKind.NO_GO and len(args) == 4:
        return kind, args[0], f"in {args[1]}: leaving by {args[2]},{args[3]}"
    if kind is AlertKind.TRAPPED and len(args) == 2:
        return kind, args[0], f"in {args[1]}: every way out crosses another zone"
    return None


def refusal_text(report: Rejections) -> str:
    """`12 in all; most: percept from tester: percept not ground ×9`."""
    text = f"{report.total} in all"
    if report.counts:
        kind, count = max(report.counts.items(), key=lambda item: item[1])
        text += f"; most: {kind} ×{count}"
    return text


def question_text(q: OperatorQuestion) -> str:
    """A pending question on the strip: what is asked, the choices, the key to answer."""
    return f"{q.agent} asks {q.question!r} ({' / '.join(q.choices)}): O to answer"


def gave_up_text(report: GoalGaveUp) -> str:
    """`budget_exhausted (last cause: link_down)`."""
    return f"{report.reason.value} (last cause: {report.cause or 'none'})"


class AlertsModel:
    """Alerts by key, newest last; `apply` returns the alerts a message raised."""

    def __init__(self, battery_low: float = BATTERY_LOW,
                 rules: tuple[AlertRule, ...] = ()) -> None:
        self.battery_low = battery_low
        self.rules = rules
        self.alerts: dict[tuple[str, str], Alert] = {}

    def apply(self, env: Envelope) -> list[Alert]:
        body = env.body
        if isinstance(body, RobotData):
            raised = self._rules(body, env.ts) if self.rules else []
            level = battery_percent(body.data)
            if level is None:
                return raised
            return raised + self._condition(AlertKind.BATTERY_LOW, body.robot,
                                            level < self.battery_low, f"{level:.0f}%", env.ts)
        if isinstance(body, RobotState):
            raised = self._condition(AlertKind.LINK_DOWN, body.robot, body.link is LinkState.DOWN,
                                     body.reason, env.ts)
            raised += self._condition(AlertKind.UNAVAILABLE, body.robot,
                                      not body.available and body.link != "down",
                                      body.reason, env.ts)
            return raised
        if isinstance(body, Percept):
            literal = body.literal.strip()
            fence = geofence_args(literal)
            if fence is not None:
                return self._condition(fence[0], fence[1], body.op == "add", fence[2], env.ts)
            if body.op == "add" and literal.startswith("hotspot_detected("):
                return [self._event(AlertKind.HOTSPOT, literal, "found", env.ts)]
            return []
        if isinstance(body, OperatorQuestion):
            return self._condition(AlertKind.QUESTION, body.id, body.state is
                                   QuestionState.PENDING, question_text(body), env.ts)
        if isinstance(body, GoalGaveUp):
            return [self._event(AlertKind.GOAL_GAVE_UP, f"{body.agent}: {body.goal}",
                                gave_up_text(body), env.ts)]
        if isinstance(body, SupEvent) and body.event in (NODE_DOWN, NODE_UP):
            return self._condition(AlertKind.NODE_DOWN, f"node {body.child}",
                                   body.event == NODE_DOWN, body.reason, env.ts)
        if isinstance(body, Rejections):
            return self._condition(AlertKind.REFUSED, body.component, body.total > 0,
                                   refusal_text(body), env.ts)
        if isinstance(body, SupEvent) and body.event is SupEventKind.TREE:
            tree = body.detail.get("tree")
            # a component's own tree (the RCL's robot actors) hangs under the component
            parent = env.src if body.detail.get("scope") == "component" else ""
            return self._budgets(tree, parent, env.ts) if isinstance(tree, dict) else []
        if isinstance(body, SupEvent):
            kind = {"restart": AlertKind.RESTARTED, "hang": AlertKind.HUNG,
                    "give_up": AlertKind.GAVE_UP, "quarantine": AlertKind.QUARANTINED
                    }.get(body.event)
            if kind is None:
                return []
            subject = f"{body.supervisor}/{body.child}" if body.supervisor else body.child
            return [self._event(kind, subject, body.reason, env.ts)]
        return []

    def goal_failed(self, goal: str, robot: str, ts: float, why: str = "") -> Alert:
        """A mission goal ended failed (from the agent's beliefs, `mrss.tui.models.goals`),
        with the reason: the agent's, else its last action's."""
        text = " ".join(p for p in (f"({robot})" if robot else "", why) if p)
        return self._event(AlertKind.GOAL_FAILED, goal, text, ts)

    def reassigned(self, task: str, lost_from: str, robot: str, ts: float,
                   why: str = "") -> Alert:
        """A task addressed to a role went from a lost robot to another
        (`mrss.tui.models.tasks`): one alert per task, counted when it happens again."""
        text = f"from {lost_from} to {robot}" + (f" ({lost_from}: {why})" if why else "")
        return self._event(AlertKind.REASSIGNED, task, text, ts)

    def _budgets(self, tree: dict[str, Any], parent: str, ts: float) -> list[Alert]:
        """Each child whose next restart or the one after would exceed its budget (the
        count its supervisor reports in the tree) is a condition until it drops."""
        raised: list[Alert] = []
        ident = tree.get("id")
        if not isinstance(ident, str):
            return raised
        path = f"{parent}/{ident}" if parent else ident
        used = nearly_used(tree.get("budget"))
        if used is not None:
            raised += self._condition(AlertKind.BUDGET, path, bool(used), used, ts)
        children = tree.get("children")
        for child in children if isinstance(children, list) else ():
            if isinstance(child, dict):
                raised += self._budgets(child, path, ts)
        return raised

    def _rules(self, body: RobotData, ts: float) -> list[Alert]:
        raised: list[Alert] = []
        for rule in self.rules:
            if rule.robot and rule.robot != body.robot:
                continue
            value = rule.value(body.data)
            if value is not None:
                raised += self._condition(AlertKind.RULE, body.robot, rule.on(value),
                                          rule.text(value), ts, rule)
        return raised

    def _condition(self, kind: AlertKind, subject: str, on: bool, text: str,
                   ts: float, rule: AlertRule | None = None) -> list[Alert]:
        alert = self.alerts.get((rule.name if rule else kind.value, subject))
        if not on:
            if alert is not None and not alert.resolved:
                alert.resolved = True
            return []
        if alert is not None and not alert.resolved:
            alert.text = text  # still on: the latest detail, no new alert
            return []
        return [self._event(kind, subject, text, ts, rule)]

    def _event(self, kind: AlertKind, subject: str, text: str, ts: float,
               rule: AlertRule | None = None) -> Alert:
        alert = self.alerts.pop((rule.name if rule else kind.value, subject), None)
        if alert is None:
            alert = Alert(kind, subject, text, ts, name=rule.name if rule else "",
                          severe_rule=rule is not None and rule.severity is Severity.SEVERE)
        else:
            alert.count += 1
            alert.text, alert.ts, alert.acked, alert.resolved = text, ts, False, False
        self.alerts[alert.key] = alert  # newest last
        while len(self.alerts) > HISTORY_LIMIT:
            del self.alerts[next(iter(self.alerts))]
        return alert

    def unacked(self) -> list[Alert]:
        """Alerts not acknowledged yet, newest first."""
        return [a for a in reversed(self.alerts.values()) if not a.acked]

    def history(self) -> list[Alert]:
        """Every alert kept, newest first."""
        return list(reversed(self.alerts.values()))

    def acknowledge(self) -> int:
        """Acknowledge every alert; how many were new."""
        new = self.unacked()
        for alert in new:
            alert.acked = True
        return len(new)

    def acknowledge_one(self, key: tuple[str, str]) -> bool:
        """Acknowledge the alert `key` (`Alert.key`); False if it is unknown or was acked."""
        alert = self.alerts.get(key)
        if alert is None or alert.acked:
            return False
        alert.acked = True
        return True
