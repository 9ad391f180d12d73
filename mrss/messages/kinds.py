"""The kinds of bus message: one frozen dataclass per kind, and `KINDS`.

One idea in one module (~420 lines): the list of what the bus carries, read as one
table; each kind is a few lines.

Their closed sets (action states, causes, commands, event names) are closed_sets.py.

Each kind has its fields (type-checked on decode by `mrss.messages.codec`), the topic
it is published on, and `validate` for checks beyond types.

One idea in one module: the catalogue of what may travel on the bus, read as one list
(`KINDS`), so it grows past 400 lines with the kinds rather than being cut by size.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from enum import StrEnum
from typing import Any, ClassVar

from mrss.errors import DecodeError
from mrss.messages import bid_reports
from mrss.messages.closed_sets import (
    CONTROL_COMMANDS,
    CONTROL_TARGETS,
    ActionState,
    AllocationState,
    AnswerVerdict,
    ControlCommand,
    ControlTarget,
    EventStatus,
    FailureCause,
    GiveUpReason,
    LinkState,
    QuestionState,
    StandDownMode,
    SupEventKind,
    WaitReason,
)
from mrss.messages.credentials import MAX_RUN

SCHEMA_VERSION = 1

JsonValue = Any  # msgpack-able: None, bool, int, float, str, bytes, list, dict


_ACTION_STATES = frozenset(ActionState)
_FAILURE_CAUSES = frozenset(FailureCause)
_LINK_STATES = frozenset(LinkState)
_SUP_EVENTS = frozenset(SupEventKind)
_GIVE_UP_REASONS = frozenset(GiveUpReason)


def _closed(msg: object, **fields: type[StrEnum]) -> None:
    """Hold each closed-set field as its enum, whoever built the message (the codec gives
    the enum already; code and tests may pass the plain value). A value outside the set
    is left for `validate` to refuse with its name."""
    for name, closed_set in fields.items():
        value = getattr(msg, name)
        member = closed_set._value2member_map_.get(value) if isinstance(value, str) else None
        if member is not None and value is not member:
            object.__setattr__(msg, name, member)


class Message:
    """Base of all message bodies: a `kind` name and a `topic` to publish on."""

    kind: ClassVar[str]

    def topic(self) -> str:
        return self.kind

    def validate(self) -> None:
        """Checks beyond field types; raise DecodeError."""


@dataclass(frozen=True)
class Percept(Message):
    """An outside event for the reasoner, as an AgentSpeak literal string."""

    kind: ClassVar[str] = "percept"
    literal: str
    op: str = "add"  # "add" | "remove"

    def validate(self) -> None:
        if self.op not in ("add", "remove"):
            raise DecodeError(f"percept op must be 'add' or 'remove', not {self.op!r}")
        if not self.literal.strip():
            raise DecodeError("percept literal is empty")


@dataclass(frozen=True)
class ActionRequest(Message):
    """An environment action of the agent, to be refined into skills by the RCL."""

    kind: ClassVar[str] = "action.request"
    uuid: str
    name: str
    args: list[JsonValue]
    robot: str = ""
    goal: str = ""
    priority: int = 0
    literal: str = ""
    #: A task addressed to a role instead of a robot (robot ""): {"capabilities": [...],
    #: "near": [lat, lon]} (mrss.actors.rcl.allocation.task); the RCL picks the robot.
    role: dict[str, JsonValue] = field(default_factory=dict)

    def validate(self) -> None:
        _nonempty(self.uuid, "uuid")
        _nonempty(self.name, "name")


@dataclass(frozen=True)
class ActionAck(Message):
    """The RCL has the action (reliable channel acknowledgement)."""

    kind: ClassVar[str] = "action.ack"
    uuid: str


@dataclass(frozen=True)
class ActionStatus(Message):
    """A transition of an action; terminal ones release the reasoner's latch."""

    kind: ClassVar[str] = "action.status"
    uuid: str
    state: ActionState
    reason: str = ""
    progress: dict[str, JsonValue] = field(default_factory=dict)
    robot: str = ""
    cause: FailureCause = FailureCause.UNSPECIFIED  # why a failed action failed
    repeat: bool = False  # the last state sent again (a reconciliation), not a transition
    name: str = ""  # the action's name and goal, so an observer that attached late knows it
    goal: str = ""
    critical: str = ""  # the critical section a skill of it is in (Skill.critical), or ""
    critical_bound: float = 0.0  # its declared bound, seconds
    deferring: bool = False  # a stop (suspend, cancel, pre-emption) waits for it to end
    # RUNNING: the longest its skills go without news (Skill.progress_bound), seconds;
    # 0: no promise. Absent in older recordings (decoded as 0).
    progress_bound: float = 0.0

    def __post_init__(self) -> None:
        _closed(self, state=ActionState, cause=FailureCause)

    def validate(self) -> None:
        _nonempty(self.uuid, "uuid")
        if self.state not in _ACTION_STATES:
            raise DecodeError(f"unknown action state {self.state!r}")
        if self.cause not in _FAILURE_CAUSES:
            raise DecodeError(f"unknown failure cause {self.cause!r}")
        if self.critical_bound < 0 or (self.deferring and not self.critical):
            raise DecodeError(f"critical section {self.critical!r}: bound "
                              f"{self.critical_bound!r}, deferring {self.deferring!r}")
        if not self.progress_bound >= 0:  # NaN too
            raise DecodeError(f"progress bound {self.progress_bound!r} is not >= 0")


@dataclass(frozen=True)
class ActionQuery(Message):
    """Reconciliation: "what is the state of these actions?" The RCL answers with one
    `ActionStatus` per uuid it knows (from its journal), and, when `requester` is set,
    with an `ActionInventory` of what older incarnations of `requester` left open."""

    kind: ClassVar[str] = "action.query"
    uuids: list[str] = field(default_factory=list)
    requester: str = ""
    inc: int = 0  # the asking incarnation (inventory: actions of older ones)


@dataclass(frozen=True)
class ActionInventory(Message):
    """The actions a dead incarnation of `requester` left at the RCL: open ones, and
    ones that ended in the last `adopt_grace` seconds. Each item has uuid, literal,
    goal, robot, state, reason, cause. A new incarnation adopts them by asking again
    for the same literal (see ReasonerHost)."""

    kind: ClassVar[str] = "action.inventory"
    requester: str
    inc: int
    actions: list[dict[str, JsonValue]] = field(default_factory=list)


@dataclass(frozen=True)
class ActionControl(Message):
    """Goal management (rcl_goal_management): a command for an action, goal or robot."""

    kind: ClassVar[str] = "action.control"
    command: ControlCommand
    target: str
    target_kind: ControlTarget = ControlTarget.ACTION

    def __post_init__(self) -> None:
        _closed(self, command=ControlCommand, target_kind=ControlTarget)

    def validate(self) -> None:
        if self.command not in CONTROL_COMMANDS:
            raise DecodeError(f"unknown control command {self.command!r}")
        if self.target_kind not in CONTROL_TARGETS:
            raise DecodeError(f"unknown control target kind {self.target_kind!r}")
        _nonempty(self.target, "target")


@dataclass(frozen=True)
class DataRequest(Message):
    """A grounding request or external function call for the data layer."""

    kind: ClassVar[str] = "dl.request"
    request_id: str
    function: str
    args: list[JsonValue] = field(default_factory=list)

    def validate(self) -> None:
        _nonempty(self.request_id, "request_id")
        _nonempty(self.function, "function")


@dataclass(frozen=True)
class DataReply(Message):
    """The data layer's answer to a request: a result, or an error text; `transient`
    when the error is a dependency that was away (worth another try)."""

    kind: ClassVar[str] = "dl.reply"
    request_id: str
    ok: bool
    result: JsonValue = None
    error: str = ""
    transient: bool = False


@dataclass(frozen=True)
class RobotState(Message):
    """A robot's availability and link state, as the RCL or a link sees it; `cause`,
    why an unavailable robot is (its actions fail with it: `decommissioned` when the
    operator took it out of service), "" when available or not said."""

    kind: ClassVar[str] = "robot.state"
    robot: str
    available: bool
    link: LinkState = LinkState.UP
    reason: str = ""
    attributes: dict[str, JsonValue] = field(default_factory=dict)
    cause: FailureCause = FailureCause.UNSPECIFIED

    def __post_init__(self) -> None:
        _closed(self, link=LinkState, cause=FailureCause)

    def validate(self) -> None:
        if self.link not in _LINK_STATES:
            raise DecodeError(f"unknown link state {self.link!r}")
        if self.cause not in _FAILURE_CAUSES:
            raise DecodeError(f"unknown cause {self.cause!r}")

    def topic(self) -> str:
        return f"robot.{self.robot}.state"


@dataclass(frozen=True)
class RobotData(Message):
    """Telemetry from a robot (position, battery, ...) for the data layer and TUI."""

    kind: ClassVar[str] = "robot.data"
    robot: str
    data: dict[str, JsonValue]

    def topic(self) -> str:
        return f"robot.{self.robot}.data"


@dataclass(frozen=True)
class SupEvent(Message):
    """A supervision event: start, exit, restart, escalate, give_up, quarantine, release."""

    kind: ClassVar[str] = "sup.event"
    event: SupEventKind
    child: str
    supervisor: str = ""
    pid: int = 0
    reason: str = ""
    count: int = 0
    detail: dict[str, JsonValue] = field(default_factory=dict)
    node: str = ""  # the node whose supervisor emitted it ("" on a single host)

    def __post_init__(self) -> None:
        _closed(self, event=SupEventKind)

    def validate(self) -> None:
        if self.event not in _SUP_EVENTS:
            raise DecodeError(f"unknown supervision event {self.event!r}")

    def topic(self) -> str:
        return f"sup.{self.event}"


@dataclass(frozen=True)
class NodeBeat(Message):
    """A node is alive: sent by its bus proxy to every peer node (never to local
    subscribers). `boot` is random per proxy start, so two processes running as one node
    are told apart; `components` are the node's component ids; `key` is the hex of the
    node's incarnation key, for the peer's border (mrss/bus/border.py; "": none), and
    `run` the number of the run that key is for (mrss/messages/credentials.py; 0: none).
    Beats travel only on the CurveZMQ links between nodes, encrypted."""

    kind: ClassVar[str] = "node.beat"
    node: str
    boot: str
    components: list[str] = field(default_factory=list)
    key: str = field(default="", repr=False)
    run: int = 0

    def topic(self) -> str:
        return f"node.beat.{self.node}"

    def validate(self) -> None:
        _nonempty(self.node, "node")
        _nonempty(self.boot, "boot")
        if not 0 <= self.run <= MAX_RUN:
            raise DecodeError(f"node {self.node}'s run {self.run} is not between 0 and "
                              f"{MAX_RUN}")


@dataclass(frozen=True)
class Heartbeat(Message):
    """A component is alive; the supervisor counts missed ones as a hang."""

    kind: ClassVar[str] = "sup.heartbeat"
    component: str
    pid: int

    def topic(self) -> str:
        return f"sup.heartbeat.{self.component}"


@dataclass(frozen=True)
class LogRecord(Message):
    """One log line of a component, for the TUI and the log file alike."""

    kind: ClassVar[str] = "log.record"
    component: str
    level: str
    message: str

    def topic(self) -> str:
        return f"log.{self.component}"


@dataclass(frozen=True)
class MindSnapshot(Message):
    """The reasoner's beliefs, intentions and pending events, for the mind inspector."""

    kind: ClassVar[str] = "mind.snapshot"
    agent: str
    beliefs: list[str]
    intentions: list[dict[str, JsonValue]]
    events: list[str]

    def topic(self) -> str:
        return f"mind.{self.agent}"


@dataclass(frozen=True)
class GoalGaveUp(Message):
    """An agent gave a goal up for good: the operator's alert (docs/mission.md, "When the
    agent gives up"). `goal` is the goal's text, `reason` why it was given up, `cause`
    the last failure's cause (`error(E)`: link_down, action_failed, ...) and `message`
    its text (file:line of the plan that failed, when known)."""

    kind: ClassVar[str] = "agent.gave_up"
    agent: str
    goal: str
    reason: GiveUpReason
    cause: str = ""
    message: str = ""

    def __post_init__(self) -> None:
        _closed(self, reason=GiveUpReason)

    def validate(self) -> None:
        _nonempty(self.agent, "agent")
        _nonempty(self.goal, "goal")
        if self.reason not in _GIVE_UP_REASONS:
            raise DecodeError(f"unknown give-up reason {self.reason!r} (one of "
                              f"{', '.join(GiveUpReason)})")

    def topic(self) -> str:
        return f"agent.gave_up.{self.agent}"


@dataclass(frozen=True)
class Command(Message):
    """An operator command from the TUI or `mrss send` (e.g. inject a fault)."""

    kind: ClassVar[str] = "ctl.command"
    command: str
    target: str = ""
    args: dict[str, JsonValue] = field(default_factory=dict)

    def topic(self) -> str:
        return f"ctl.{self.command}"


@dataclass(frozen=True)
class EventReport(Message):
    """What became of one external event at the edge (docs/edges.md, "Event reports").

    `event_topic` is the outside (MQTT) topic it came on; `event_id` the sender's
    `"id"` when it gave one; `attempts` how often its handler ran.
    """

    kind: ClassVar[str] = "edge.report"
    component: str
    status: str
    event_topic: str
    event_id: str = ""
    reason: str = ""
    attempts: int = 0
    detail: dict[str, JsonValue] = field(default_factory=dict)

    def validate(self) -> None:
        if self.status not in EventStatus.__members__.values():
            raise DecodeError(f"event report status {self.status!r} is not one of "
                              f"{', '.join(EventStatus)}")

    def topic(self) -> str:
        return f"edge.{self.status}"


@dataclass(frozen=True)
class Rejections(Message):
    """What one component refused since it started (docs/edges.md, "Bad input").

    Sent when its counters have moved, at most every few seconds
    (`mrss.edge.rejection_reports`): `total` refusals, and the counts of the commonest
    kinds as "<what> from <source>: <reason>" -> count.
    """

    kind: ClassVar[str] = "edge.rejections"
    component: str
    total: int
    counts: dict[str, int] = field(default_factory=dict)

    def topic(self) -> str:
        return f"edge.rejections.{self.component}"


@dataclass(frozen=True)
class TaskAllocation(Message):
    """Where a task addressed to a role stands: waiting (why, as an enum, and in words)
    or awarded (to whom, and why that robot won).

    What the decision was made from, structured (mrss/messages/bid_reports.py): `bids`,
    the robots' bids in rank order (at most `bid_reports.LIMIT`; `bidders` counts them
    all), `evaluator` (the ranking's name), what the task asks (`capabilities`, `near`
    [lat, lon] or []), and `lost_from`, the robot that lost it when an award hands it on
    (a reassignment). `why` says the same in words, for logs."""

    kind: ClassVar[str] = "action.allocation"
    uuid: str
    state: AllocationState
    robot: str = ""
    wait: WaitReason = WaitReason.NONE
    why: str = ""
    name: str = ""
    goal: str = ""
    bids: list[dict[str, JsonValue]] = field(default_factory=list)
    bidders: int = 0
    evaluator: str = ""
    capabilities: list[str] = field(default_factory=list)
    near: list[float] = field(default_factory=list)
    lost_from: str = ""

    def __post_init__(self) -> None:
        _closed(self, state=AllocationState, wait=WaitReason)

    def validate(self) -> None:
        _nonempty(self.uuid, "uuid")
        if self.state not in frozenset(AllocationState):
            raise DecodeError(f"unknown allocation state {self.state!r}")
        if self.wait not in frozenset(WaitReason):
            raise DecodeError(f"unknown wait reason {self.wait!r}")
        bid_reports.check(self.bids)
        if self.near and len(self.near) != 2:
            raise DecodeError(f"near must be [lat, lon] or [], not {self.near!r}")


@dataclass(frozen=True)
class StandDownState(Message):
    """An operator's stand-down by area as the RCL executes it (mrss.actors.rcl
    .stand_down): sent when it is made and when it is lifted, and again on a snapshot.
    `area` is the GeoJSON Polygon (lon, lat); `capabilities` what a robot must have to be
    concerned ([]: every robot); `robots` those inside by their own last position, held;
    `notes` what differed from the operator's picture (a robot named but outside, one
    with no position yet)."""

    kind: ClassVar[str] = "fleet.stand_down"
    ident: str
    mode: StandDownMode
    active: bool
    area: dict[str, JsonValue] = field(default_factory=dict)
    capabilities: list[str] = field(default_factory=list)
    robots: list[str] = field(default_factory=list)
    notes: list[str] = field(default_factory=list)
    by: str = ""

    def __post_init__(self) -> None:
        _closed(self, mode=StandDownMode)

    def validate(self) -> None:
        _nonempty(self.ident, "ident")
        if self.mode not in frozenset(StandDownMode):
            raise DecodeError(f"unknown stand-down mode {self.mode!r}")

    def topic(self) -> str:
        return f"fleet.stand_down.{self.ident}"


@dataclass(frozen=True)
class OperatorQuestion(Message):
    """A question an agent asks the operator (`.ask_operator`), as it stands now: sent on
    each transition and again (`repeat`) when a dashboard asks (`ctl.questions`).
    `deadline` is wall-clock time (0: none); `answer` and `by` once it is not pending."""

    kind: ClassVar[str] = "question"
    id: str
    agent: str
    question: str
    choices: list[str]
    state: QuestionState
    default: str = ""
    deadline: float = 0.0
    asked_at: float = 0.0
    answer: str = ""
    by: str = ""
    answered_at: float = 0.0
    repeat: bool = False

    def __post_init__(self) -> None:
        _closed(self, state=QuestionState)

    def validate(self) -> None:
        _nonempty(self.id, "id")
        if self.state not in frozenset(QuestionState):
            raise DecodeError(f"unknown question state {self.state!r} (one of "
                              f"{', '.join(QuestionState)})")

    def topic(self) -> str:
        return f"question.{self.agent}"


@dataclass(frozen=True)
class QuestionAnswer(Message):
    """An operator's answer to a question: sent again until an `AnswerReply` with its
    `request` comes (the reasoner answers a repeat as it answered the first)."""

    kind: ClassVar[str] = "question.answer"
    id: str
    answer: str
    by: str
    request: str

    def validate(self) -> None:
        for name in ("id", "answer", "by", "request"):
            _nonempty(getattr(self, name), name)


@dataclass(frozen=True)
class AnswerReply(Message):
    """The reasoner's word on an answer: taken, or why not (in `message`)."""

    kind: ClassVar[str] = "question.reply"
    request: str
    id: str
    verdict: AnswerVerdict
    message: str = ""

    def __post_init__(self) -> None:
        _closed(self, verdict=AnswerVerdict)

    def validate(self) -> None:
        if self.verdict not in frozenset(AnswerVerdict):
            raise DecodeError(f"unknown answer verdict {self.verdict!r}")


KINDS: dict[str, type[Message]] = {
    cls.kind: cls
    for cls in (
        Percept, ActionRequest, ActionAck, ActionStatus, ActionControl, ActionQuery,
        ActionInventory, DataRequest,
        DataReply, RobotState, RobotData, SupEvent, NodeBeat, Heartbeat, LogRecord, MindSnapshot,
        Command, EventReport, Rejections, GoalGaveUp, TaskAllocation, OperatorQuestion,
        QuestionAnswer, AnswerReply, StandDownState,
    )
}


def _nonempty(value: str, name: str) -> None:
    if not value:
        raise DecodeError(f"field {name!r} is empty")
