"""Mission figures from a recording, as field teams compute them after an exercise
(`mrss recording report`).

Read from the bus messages of the recording, in order, timed by the recorder's clock
(one clock for every sender; a message the reliable channel delivered twice counted
once):

* a **goal** is what the agent's actions name as theirs (`action.request` `goal`); it was
  **reported** by the first percept whose first argument names it (the operator's area
  goal, a world-model rule's hotspot); service actions (a recharge) name a goal no
  percept reported and are shown apart. Per goal: report -> first action, report ->
  done, its actions and robots, and how it ended: `done` (its last action succeeded),
  `gave_up` (the agent gave it up: agent.gave_up), `cancelled`, `failed`, or `open`.
* **actions** per robot and final state (each action once, by uuid), failures by cause.
* **restarts and faults**: `sup.restart` per component; exits other than a shutdown,
  hangs, quarantines, escalations, give-ups, nodes lost.
* **robot losses** (a robot that was up becoming unavailable or its link not up, once per
  change)
  and **reassignments** (the RCL's `reassigned(...)` percepts, an allocated task awarded
  to another robot than before).
* **operator interventions**: operator commands (`ctl.*`, not the dashboard's polls), a
  percept from a sender that is not a component (the dashboard, `mrss send`), and an
  operator event the events manager accepted on an `[operator]` topic other than `area`
  (an area is a tasking: it reports a goal). An intervention is on a goal when it names
  the goal or one of its robots while the goal is open (for an operator event: the
  percepts its component sent for it). A goal is done **without an operator** when it
  was done and no intervention was on it.

Components are what supervisors start (the children of `sup.*` events) and the senders
of heartbeats; the `[operator]` topics come from the project.toml kept in the recording
(`mrss record --project`).
"""

from __future__ import annotations

import enum
import re
from collections import Counter
from collections.abc import Iterable
from dataclasses import dataclass, field

from mrss.messages import (
    ActionRequest,
    ActionState,
    ActionStatus,
    AllocationState,
    Command,
    Envelope,
    EventReport,
    GoalGaveUp,
    Heartbeat,
    Percept,
    RobotState,
    SupEvent,
    SupEventKind,
    TaskAllocation,
)

QUIET_COMMANDS = frozenset({"mind", "tree", "snapshot"})  # a dashboard's polling
FAULTS = frozenset({SupEventKind.EXIT, SupEventKind.HANG, SupEventKind.QUARANTINE,
                    SupEventKind.ESCALATE, SupEventKind.GIVE_UP, SupEventKind.NODE_DOWN})
TERMINAL = frozenset({ActionState.SUCCEEDED, ActionState.FAILED, ActionState.CANCELLED})
_FIRST_ARG = re.compile(r'\s*~?[a-z]\w*\s*\(\s*"?([^,()"\s]+)')
_WORD = re.compile(r"[A-Za-z0-9_]+")


class GoalOutcome(enum.StrEnum):
    """How a goal ended, as far as the recording goes."""

    DONE = "done"
    GAVE_UP = "gave_up"
    CANCELLED = "cancelled"
    FAILED = "failed"
    OPEN = "open"


@dataclass
class Goal:
    name: str
    reported: float | None = None
    first_action: float | None = None
    ended: float | None = None  # when its last action ended (or it was given up)
    last_state: ActionState | None = None
    gave_up: bool = False
    actions: list[str] = field(default_factory=list)  # uuids, in order
    robots: set[str] = field(default_factory=set)
    interventions: int = 0

    @property
    def outcome(self) -> GoalOutcome:
        if self.gave_up:
            return GoalOutcome.GAVE_UP
        if self.last_state is ActionState.SUCCEEDED:
            return GoalOutcome.DONE
        if self.last_state is ActionState.CANCELLED:
            return GoalOutcome.CANCELLED
        if self.last_state is ActionState.FAILED:
            return GoalOutcome.FAILED
        return GoalOutcome.OPEN

    def open_at(self, ts: float) -> bool:
        start = self.reported if self.reported is not None else self.first_action
        return start is not None and start <= ts and (self.ended is None or ts <= self.ended)


@dataclass(frozen=True)
class Intervention:
    ts: float
    who: str
    what: str
    words: frozenset[str]  # what it names: goals, robots


@dataclass
class Figures:
    """The figures of one recording."""

    first: float | None = None
    last: float | None = None
    goals: dict[str, Goal] = field(default_factory=dict)
    actions: Counter[tuple[str, str]] = field(default_factory=Counter)  # (robot, state)
    causes: Counter[tuple[str, str]] = field(default_factory=Counter)  # (robot, cause)
    restarts: Counter[str] = field(default_factory=Counter)
    faults: Counter[tuple[str, str]] = field(default_factory=Counter)  # (event, child)
    losses: list[tuple[float, str, str]] = field(default_factory=list)  # ts, robot, why
    reassignments: list[tuple[float, str]] = field(default_factory=list)
    interventions: list[Intervention] = field(default_factory=list)

    @property
    def hours(self) -> float:
        if self.first is None or self.last is None:
            return 0.0
        return (self.last - self.first) / 3600

    @property
    def reported_goals(self) -> list[Goal]:
        return [g for g in self.goals.values() if g.reported is not None]

    @property
    def without_operator(self) -> list[Goal]:
        return [g for g in self.reported_goals
                if g.outcome is GoalOutcome.DONE and not g.interventions]


def first_argument(literal: str) -> str | None:
    """The first argument of a literal's text (`hotspot_detected(h1, ...)` -> `h1`)."""
    match = _FIRST_ARG.match(literal)
    return match.group(1) if match else None


class FigureCounter:
    """Takes the recording's envelopes in order; `figures()` when all are in.

    `operator_topics` are the project's `[operator]` topics other than the area's: its
    events are interventions."""

    def __init__(self, *, operator_topics: Iterable[str] = ()) -> None:
        self.operator_topics = frozenset(operator_topics)
        self.result = Figures()
        self._seen: set[tuple[str, str]] = set()
        self._components: set[str] = {"supervisor"}
        self._percepts: list[tuple[float, str, Percept]] = []  # ts, src, percept
        self._pending: dict[str, list[str]] = {}  # src -> its percepts since its last report
        self._requests: dict[str, ActionRequest] = {}
        self._final: dict[str, tuple[str, ActionState, str]] = {}  # uuid -> robot, state, cause
        self._awarded: dict[str, str] = {}
        self._robots: dict[str, bool] = {}

    def take(self, env: Envelope, at: float) -> None:
        """One envelope, recorded at `at` (the recorder's clock: one clock for all)."""
        key = (env.src, env.id)
        if key in self._seen:
            return
        self._seen.add(key)
        figures = self.result
        figures.first = at if figures.first is None else min(figures.first, at)
        figures.last = at if figures.last is None else max(figures.last, at)
        body = env.body
        if isinstance(body, Heartbeat):
            self._components.add(env.src)
        elif isinstance(body, Percept):
            self._percept(at, env.src, body)
        elif isinstance(body, ActionRequest):
            self._request(at, body)
        elif isinstance(body, ActionStatus):
            self._status(at, body)
        elif isinstance(body, GoalGaveUp):
            goal = self._goal(body.goal)
            goal.gave_up = True
            goal.ended = at
        elif isinstance(body, Command) and body.command not in QUIET_COMMANDS:
            args = " ".join(f"{k}={v}" for k, v in body.args.items())
            self._intervene(at, env.src, f"ctl.{body.command} {body.target} {args}".strip())
        elif isinstance(body, EventReport):
            self._report(at, env.src, body)
        elif isinstance(body, SupEvent):
            self._supervision(body)
        elif isinstance(body, RobotState):
            self._robot(at, body)
        elif isinstance(body, TaskAllocation) and body.state is AllocationState.AWARDED:
            before = self._awarded.get(body.uuid)
            if before is not None and before != body.robot:
                figures.reassignments.append(
                    (at, f"{body.name or body.uuid[:8]}: {before} -> {body.robot}"))
            self._awarded[body.uuid] = body.robot

    def _goal(self, name: str) -> Goal:
        goal = self.result.goals.get(name)
        if goal is None:
            goal = self.result.goals[name] = Goal(name)
        return goal

    def _percept(self, at: float, src: str, body: Percept) -> None:
        if body.literal.startswith("reassigned("):
            self.result.reassignments.append((at, body.literal))
        self._percepts.append((at, src, body))
        self._pending.setdefault(src, []).append(body.literal)

    def _request(self, at: float, body: ActionRequest) -> None:
        self._requests[body.uuid] = body
        if not body.goal:
            return
        goal = self._goal(body.goal)
        if body.uuid not in goal.actions:
            goal.actions.append(body.uuid)
        if goal.first_action is None:
            goal.first_action = at
        if body.robot:
            goal.robots.add(body.robot)

    def _status(self, at: float, body: ActionStatus) -> None:
        if body.state not in TERMINAL:
            return
        request = self._requests.get(body.uuid)
        robot = body.robot or (request.robot if request else "") or "?"
        self._final[body.uuid] = (robot, body.state, body.cause.value)
        name = body.goal or (request.goal if request else "")
        if not name:
            return
        goal = self._goal(name)
        if goal.actions and goal.actions[-1] != body.uuid:
            return  # an older action of the goal ended late: its latest one decides
        goal.last_state = body.state
        goal.ended = at
        if robot != "?":
            goal.robots.add(robot)

    def _report(self, at: float, src: str, body: EventReport) -> None:
        percepts = self._pending.pop(src, [])
        if body.status != "accepted" or body.event_topic not in self.operator_topics:
            return
        self._intervene(at, f"mqtt:{body.event_topic}",
                        f"{body.event_topic}: {'; '.join(percepts) or body.event_id}")

    def _intervene(self, ts: float, who: str, what: str) -> None:
        self.result.interventions.append(
            Intervention(ts, who, what, frozenset(_WORD.findall(what))))

    def _supervision(self, body: SupEvent) -> None:
        self._components.add(body.child)  # what a supervisor starts is a component
        if body.supervisor:
            self._components.add(body.supervisor)
        if body.event is SupEventKind.RESTART:
            self.result.restarts[body.child] += 1
        elif body.event in FAULTS and not (body.event is SupEventKind.EXIT
                                           and body.reason.startswith("shutdown")):
            self.result.faults[(body.event.value, body.child)] += 1

    def _robot(self, ts: float, body: RobotState) -> None:
        up = body.available and body.link.value == "up"
        # a loss is a robot that was up going down: one not heard up yet (the RCL's start,
        # waiting for its link's first report) has nothing to lose
        if self._robots.get(body.robot, False) and not up:
            self.result.losses.append((ts, body.robot, body.reason or f"link {body.link.value}"))
        self._robots[body.robot] = up

    def figures(self) -> Figures:
        """The figures, once every envelope has been taken."""
        figures = self.result
        reports: dict[str, int] = {}  # goal -> the percept that reported it
        for index, (ts, _, percept) in enumerate(self._percepts):
            name = first_argument(percept.literal)
            goal = figures.goals.get(name) if name else None
            if goal is not None and percept.op == "add" and goal.reported is None:
                goal.reported = ts
                reports[goal.name] = index
        tasking = set(reports.values())
        for index, (ts, src, percept) in enumerate(self._percepts):
            if src not in self._components and index not in tasking:  # dashboard, mrss send
                self._intervene(ts, src, f"percept {percept.op} {percept.literal}")
        figures.interventions.sort(key=lambda i: i.ts)
        for goal in figures.goals.values():
            names = {goal.name, *goal.robots}
            goal.interventions = sum(1 for i in figures.interventions
                                     if goal.open_at(i.ts) and names & i.words)
        for robot, state, cause in self._final.values():
            figures.actions[(robot, state.value)] += 1
            if state is ActionState.FAILED:
                figures.causes[(robot, cause or "unspecified")] += 1
        return figures
