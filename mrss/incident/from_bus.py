"""Which bus messages become rows of the incident record, and how they read.

`Classifier.entry` turns one message into a row, or None for the traffic that is not
mission history (telemetry, heartbeats, the dashboard's polls, data requests). It
keeps a little state: a robot's availability is recorded when it changes, not each
time it is repeated, and a repeated action status (a reconciliation) is not a new
outcome.
"""

from __future__ import annotations

from collections import OrderedDict
from collections.abc import Callable, Collection
from typing import Any

from mrss.incident.entries import Entry, IncidentKind, Level
from mrss.messages import (
    ActionRequest,
    ActionState,
    ActionStatus,
    AllocationState,
    Command,
    Envelope,
    EventReport,
    GoalGaveUp,
    Message,
    OperatorQuestion,
    Percept,
    QuestionState,
    RobotState,
    StandDownState,
    SupEvent,
    SupEventKind,
    TaskAllocation,
)

#: The bus topics a recorder subscribes to: everything `Classifier` may record.
TOPICS = ("action.request", "action.status", "action.allocation", "rel.action.", "percept",
          "ctl.", "edge.", "agent.gave_up", "robot.", "sup.", "question.", "fleet.")
SEEN = 10_000  # envelope ids remembered: the reliable channel may deliver one again
QUIET_COMMANDS = frozenset({"mind", "tree", "snapshot", "questions"})  # a dashboard's polling
ENDED = {ActionState.SUCCEEDED: Level.INFO, ActionState.FAILED: Level.WARNING,
         ActionState.CANCELLED: Level.INFO}
SUP_LEVELS = {SupEventKind.RESTART: Level.WARNING, SupEventKind.EXIT: Level.WARNING,
              SupEventKind.HANG: Level.ALERT, SupEventKind.ESCALATE: Level.ALERT,
              SupEventKind.GIVE_UP: Level.ALERT, SupEventKind.QUARANTINE: Level.ALERT,
              SupEventKind.RELEASE: Level.INFO, SupEventKind.NODE_DOWN: Level.ALERT,
              SupEventKind.NODE_UP: Level.INFO, SupEventKind.STOPPING: Level.INFO}


class Classifier:
    """Bus messages to incident rows; `operator_topics` are the MQTT topics of the
    project's operator commands, `components` the project's component ids (a percept
    from anyone else is an operator's)."""

    def __init__(self, *, operator_topics: Collection[str] = (),
                 components: Collection[str] = (),
                 author: Callable[[Envelope], str] | None = None) -> None:
        self.operator_topics = frozenset(operator_topics)
        # who sent an operator's command: the user its credential proves (the root's
        # `mrss.runtime.incident_recorder` checks it), else its sender
        self.author = author or (lambda env: env.src)
        self.components = frozenset(components)
        self._available: dict[str, tuple[bool, str]] = {}
        self._stand_downs: dict[str, tuple[bool, tuple[str, ...]]] = {}  # what was recorded
        self._seen: OrderedDict[tuple[str, str], None] = OrderedDict()

    def entry(self, env: Envelope) -> Entry | None:
        """The row for one envelope; None for a repeat of one already seen."""
        key = (env.src, env.id)
        if key in self._seen:
            return None
        self._seen[key] = None
        if len(self._seen) > SEEN:
            self._seen.popitem(last=False)
        operator = isinstance(env.body, (Command, Percept))
        return self.of(env.body, ts=env.ts, src=env.src,
                       who=self.author(env) if operator else "")

    def of(self, body: Message, *, ts: float, src: str, who: str = "") -> Entry | None:
        """The row for one message (sent by `src` at `ts`, by the operator `who`), or
        None."""
        if isinstance(body, ActionRequest):
            return self._request(body, ts, src)
        if isinstance(body, ActionStatus):
            return self._status(body, ts, src)
        if isinstance(body, TaskAllocation):
            return self._allocation(body, ts, src)
        if isinstance(body, Percept):
            return self._percept(body, ts, src, who or src)
        if isinstance(body, Command) and body.command not in QUIET_COMMANDS:
            args = " ".join(f"{k}={v}" for k, v in body.args.items())
            return Entry(ts, IncidentKind.OPERATOR, f"ctl.{body.command} {body.target} {args}"
                         .strip().replace("  ", " "), subject=body.target, source=src,
                         who=who or src, detail={"command": body.command, "args": body.args})
        if isinstance(body, EventReport):
            return self._report(body, ts, src)
        if isinstance(body, GoalGaveUp):
            cause = f", last cause {body.cause}" if body.cause else ""
            return Entry(ts, IncidentKind.GAVE_UP, f"{body.agent} gave up {body.goal}: "
                         f"{body.reason.value}{cause}", subject=body.goal, level=Level.ALERT,
                         source=src, detail={"reason": body.reason.value, "cause": body.cause,
                                             "message": body.message})
        if isinstance(body, RobotState):
            return self._robot(body, ts, src)
        if isinstance(body, StandDownState):
            return self._stand_down(body, ts, src)
        if isinstance(body, OperatorQuestion):
            return self._question(body, ts, src)
        if isinstance(body, SupEvent):
            return self.supervision(body, ts, src)
        return None

    def supervision(self, body: SupEvent, ts: float, src: str = "supervisor") -> Entry | None:
        level = SUP_LEVELS.get(body.event)
        if level is None:
            return None  # start, tree: routine
        if body.event is SupEventKind.EXIT and body.reason.startswith("shutdown"):
            level = Level.INFO
        where = f"{body.supervisor}/{body.child}" if body.supervisor else body.child
        parts = [f"{where} {body.event.value}"]
        if body.count:
            parts.append(f"(#{body.count})")
        if body.reason:
            parts.append(f": {body.reason}")
        return Entry(ts, IncidentKind.SUPERVISION, " ".join(parts), subject=body.child,
                     level=level, source=src, detail={"event": body.event.value,
                                                      "pid": body.pid, "node": body.node})

    def _request(self, body: ActionRequest, ts: float, src: str) -> Entry:
        literal = body.literal or f"{body.name}({', '.join(map(str, body.args))})"
        where = f" on {body.robot}" if body.robot else (
            f" for a robot with {body.role.get('capabilities')}" if body.role else "")
        goal = f" for goal {body.goal}" if body.goal else ""
        return Entry(ts, IncidentKind.GOAL, f"{literal}{where}{goal}",
                     subject=body.goal or literal, source=src,
                     detail={"uuid": body.uuid, "robot": body.robot, "priority": body.priority})

    def _status(self, body: ActionStatus, ts: float, src: str) -> Entry | None:
        level = ENDED.get(body.state)
        if level is None or body.repeat:
            return None
        why = f": {body.reason}" if body.reason else ""
        cause = f" ({body.cause.value})" if body.cause.value else ""
        what = body.name or body.uuid[:8]
        robot = f" on {body.robot}" if body.robot else ""
        goal = f" for goal {body.goal}" if body.goal else ""
        return Entry(ts, IncidentKind.OUTCOME, f"{what}{robot}{goal} {body.state.value}"
                     f"{cause}{why}", subject=body.goal or what, level=level, source=src,
                     detail={"uuid": body.uuid, "state": body.state.value,
                             "cause": body.cause.value, "robot": body.robot})

    def _allocation(self, body: TaskAllocation, ts: float, src: str) -> Entry:
        what = body.name or body.uuid[:8]
        if body.state is AllocationState.AWARDED:
            text = f"{what} awarded to {body.robot}"
        else:
            text = f"{what} waits ({body.wait.value})"
        return Entry(ts, IncidentKind.ALLOCATION, text + (f": {body.why}" if body.why else ""),
                     subject=body.goal or what, source=src,
                     level=Level.INFO if body.state is AllocationState.AWARDED
                     else Level.WARNING,
                     detail={"uuid": body.uuid, "robot": body.robot,
                             "state": body.state.value, "wait": body.wait.value})

    def _percept(self, body: Percept, ts: float, src: str, who: str) -> Entry | None:
        if body.literal.startswith("reassigned("):
            return Entry(ts, IncidentKind.REASSIGNED, body.literal, subject=body.literal,
                         level=Level.WARNING, source=src)
        if src in self.components or not src:
            return None  # the events manager's and the RCL's percepts: the agent's input
        return Entry(ts, IncidentKind.OPERATOR, f"percept {body.op} {body.literal}",
                     subject=body.literal, source=src, who=who, detail={"op": body.op})

    def _report(self, body: EventReport, ts: float, src: str) -> Entry | None:
        if body.status == "duplicate":
            return None
        operator = body.event_topic in self.operator_topics
        level = Level.INFO if body.status == "accepted" else Level.WARNING
        detail: dict[str, Any] = {"status": body.status, "topic": body.event_topic,
                                  "id": body.event_id, **body.detail}
        why = f": {body.reason}" if body.reason else ""
        return Entry(ts, IncidentKind.OPERATOR if operator else IncidentKind.EVENT,
                     f"{body.event_topic} {body.status}{why}", subject=body.event_topic,
                     level=level, source=src, who=_mqtt_author(body) if operator
                     else "", detail=detail)

    def _robot(self, body: RobotState, ts: float, src: str) -> Entry | None:
        state = (body.available and body.link.value == "up", body.link.value)
        before = self._available.get(body.robot)
        if before == state:
            return None
        self._available[body.robot] = state
        if before is None:  # a robot's first state is not news: up, or not heard up yet
            return None    # (the RCL's start waits for its link's first report)
        if state[0]:
            return Entry(ts, IncidentKind.ROBOT, f"{body.robot} back", subject=body.robot,
                         source=src, detail={"link": body.link.value})
        why = body.reason or f"link {body.link.value}"
        return Entry(ts, IncidentKind.ROBOT, f"{body.robot} lost: {why}", subject=body.robot,
                     level=Level.ALERT, source=src,
                     detail={"link": body.link.value, "available": body.available})

    def _stand_down(self, body: StandDownState, ts: float, src: str) -> Entry | None:
        """A stand-down by area made, refused or lifted (its repeats on snapshots: none)."""
        state = (body.active, tuple(body.notes if not body.active else body.robots))
        if self._stand_downs.get(body.ident) == state:
            return None
        self._stand_downs[body.ident] = state
        robots = ", ".join(body.robots) or "no robot"
        if body.active:
            notes = f" ({'; '.join(body.notes)})" if body.notes else ""
            text, level = f"stand-down {body.ident} ({body.mode.value}): {robots} held{notes}", \
                Level.WARNING
        elif body.notes and body.notes[0].startswith("refused"):
            text, level = f"stand-down {body.ident} {body.notes[0]}", Level.WARNING
        else:
            text, level = f"stand-down {body.ident} lifted: {robots} go on", Level.INFO
        return Entry(ts, IncidentKind.ROBOT, text, subject=body.ident, level=level,
                     source=src, who=body.by,
                     detail={"mode": body.mode.value, "active": body.active,
                             "robots": list(body.robots), "area": body.area})

    def _question(self, body: OperatorQuestion, ts: float, src: str) -> Entry | None:
        if body.repeat:
            return None  # asked again for a late dashboard, or adopted after a restart
        detail = {"id": body.id, "state": body.state.value, "choices": body.choices,
                  "answer": body.answer, "deadline": body.deadline}
        if body.state is QuestionState.PENDING:
            return Entry(ts, IncidentKind.QUESTION, f"{body.agent} asks {body.question!r} "
                         f"({' / '.join(body.choices)})", subject=body.id,
                         level=Level.ALERT, source=src, detail=detail)
        if body.state is QuestionState.ANSWERED:
            return Entry(ts, IncidentKind.QUESTION, f"{body.question!r} answered "
                         f"{body.answer!r} by {body.by}", subject=body.id, source=src,
                         who=body.by, detail=detail)
        if body.state is QuestionState.TIMED_OUT:
            return Entry(ts, IncidentKind.QUESTION, f"{body.question!r} timed out: default "
                         f"answer {body.answer!r}", subject=body.id, level=Level.WARNING,
                         source=src, detail=detail)
        return Entry(ts, IncidentKind.QUESTION, f"{body.question!r} withdrawn by the agent",
                     subject=body.id, source=src, detail=detail)


def _mqtt_author(body: EventReport) -> str:
    """The author of an operator command over MQTT: the user its credential names (the
    events manager verified it when it accepted the command), and the topic."""
    author = body.detail.get("author")
    return f"{author} via mqtt:{body.event_topic}" if author else f"mqtt:{body.event_topic}"
