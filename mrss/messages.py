"""Every message on the MRSS bus: one frozen dataclass per kind, the envelope, the codec.

A bus message is two frames, `[topic, msgpack(envelope)]`, where the envelope is
`{v, id, ts, src, inc, kind, body}`: schema version, message id, send time, sending
component, the sender's incarnation (so a dead incarnation's late messages can be
dropped), message kind, and the kind's fields. `decode` validates all of it and raises
`DecodeError` with the reason for anything else; it never raises anything but that.
"""

from __future__ import annotations

import dataclasses
import itertools
import threading
import time
import types
import typing
import uuid as uuidlib
from dataclasses import dataclass, field
from enum import StrEnum
from typing import Any, ClassVar, Union

import msgpack

from mrss.errors import DecodeError

SCHEMA_VERSION = 1

JsonValue = Any  # msgpack-able: None, bool, int, float, str, bytes, list, dict


class Topic(StrEnum):
    """Topic prefixes; subscribers filter by prefix."""

    PERCEPT = "percept"
    ACTION_REQUEST = "action.request"
    ACTION_ACK = "action.ack"
    ACTION_STATUS = "action.status"
    ACTION_CONTROL = "action.control"
    DL_REQUEST = "dl.request"
    DL_REPLY = "dl.reply"
    ROBOT = "robot."
    SUP = "sup."
    LOG = "log."
    MIND = "mind."
    CTL = "ctl."
    EDGE = "edge."


class ActionState(StrEnum):
    """States of an action in the RCL (DESIGN.md, "Actions")."""

    PENDING = "pending"
    RUNNING = "running"
    SUSPENDED = "suspended"
    SUCCEEDED = "succeeded"
    FAILED = "failed"
    CANCELLED = "cancelled"

    @property
    def terminal(self) -> bool:
        return self in (ActionState.SUCCEEDED, ActionState.FAILED, ActionState.CANCELLED)


class FailureCause(StrEnum):
    """Why an action failed, as the agent sees it: `-!g[error(Cause)]` (Jason's failure
    reason). "" (no cause) reads `error(action_failed)`, as in Jason."""

    TRANSIENT = "transient"  # a dependency was away (RCL restart, lease, data layer): retry
    LINK_DOWN = "link_down"  # the robot's link was lost
    FAILSAFE = "failsafe"  # the robot lost its controller and went to its safe state
    CANCELLED = "cancelled"  # goal management (operator or agent) cancelled it
    QUARANTINED = "quarantined"  # the robot's actor kept crashing
    REJECTED = "rejected"  # the request was malformed or refused
    ORPHANED = "orphaned"  # its requester's incarnation died and nobody adopted it
    PREEMPTED = "preempted"  # pre-empted longer than the RCL's preempted_timeout
    NODE_DOWN = "node_down"  # the node the robot is reached through was lost


CONTROL_COMMANDS = ("cancel", "suspend", "resume", "succeed", "fail")
CONTROL_TARGETS = ("action", "goal", "robot")


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
    state: str
    reason: str = ""
    progress: dict[str, JsonValue] = field(default_factory=dict)
    robot: str = ""
    cause: str = ""  # a FailureCause value for a failed action, else ""
    repeat: bool = False  # the last state sent again (a reconciliation), not a transition
    name: str = ""  # the action's name and goal, so an observer that attached late knows it
    goal: str = ""

    def validate(self) -> None:
        _nonempty(self.uuid, "uuid")
        if self.state not in {s.value for s in ActionState}:
            raise DecodeError(f"unknown action state {self.state!r}")
        if self.cause and self.cause not in {c.value for c in FailureCause}:
            raise DecodeError(f"unknown failure cause {self.cause!r}")


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
    command: str
    target: str
    target_kind: str = "action"

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
    """A robot's availability and link state, as the RCL or a link sees it."""

    kind: ClassVar[str] = "robot.state"
    robot: str
    available: bool
    link: str = "up"  # "up" | "down"
    reason: str = ""
    attributes: dict[str, JsonValue] = field(default_factory=dict)

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
    event: str
    child: str
    supervisor: str = ""
    pid: int = 0
    reason: str = ""
    count: int = 0
    detail: dict[str, JsonValue] = field(default_factory=dict)
    node: str = ""  # the node whose supervisor emitted it ("" on a single host)

    def topic(self) -> str:
        return f"sup.{self.event}"


@dataclass(frozen=True)
class NodeBeat(Message):
    """A node is alive: sent by its bus proxy to every peer node (never to local
    subscribers). `boot` is random per proxy start, so two processes running as one node
    are told apart; `components` are the node's component ids."""

    kind: ClassVar[str] = "node.beat"
    node: str
    boot: str
    components: list[str] = field(default_factory=list)

    def topic(self) -> str:
        return f"node.beat.{self.node}"

    def validate(self) -> None:
        _nonempty(self.node, "node")
        _nonempty(self.boot, "boot")


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
class Command(Message):
    """An operator command from the TUI or `mrss send` (e.g. inject a fault)."""

    kind: ClassVar[str] = "ctl.command"
    command: str
    target: str = ""
    args: dict[str, JsonValue] = field(default_factory=dict)

    def topic(self) -> str:
        return f"ctl.{self.command}"


class EventStatus(StrEnum):
    """What became of an external event at the edge."""

    ACCEPTED = "accepted"    # its percepts went out
    REJECTED = "rejected"    # bad payload: not retried
    FAILED = "failed"        # a dependency stayed down past the retry budget, or a bug
    DUPLICATE = "duplicate"  # a redelivery of an event already handled


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


KINDS: dict[str, type[Message]] = {
    cls.kind: cls
    for cls in (
        Percept, ActionRequest, ActionAck, ActionStatus, ActionControl, ActionQuery,
        ActionInventory, DataRequest,
        DataReply, RobotState, RobotData, SupEvent, NodeBeat, Heartbeat, LogRecord, MindSnapshot,
        Command, EventReport, Rejections,
    )
}


@dataclass(frozen=True)
class Envelope:
    """A decoded bus message: header fields plus the validated body."""

    topic: str
    id: str
    ts: float
    src: str
    inc: int
    body: Message
    v: int = SCHEMA_VERSION

    @property
    def kind(self) -> str:
        return self.body.kind


def new_id() -> str:
    """A fresh message or action id."""
    return uuidlib.uuid4().hex


class IdGenerator:
    """Cheap unique message ids: a random per-instance prefix plus a counter.

    A uuid4 per message costs a system call; a publisher sending thousands of messages a
    second uses one of these instead. Ids stay unique across processes (64 random bits).
    """

    def __init__(self) -> None:
        self._prefix = uuidlib.uuid4().hex[:16]
        self._count = itertools.count()

    def __call__(self) -> str:
        return f"{self._prefix}{next(self._count):x}"


def encode(
    body: Message, *, src: str, inc: int = 0, msg_id: str | None = None,
    topic: str | None = None,
) -> tuple[bytes, bytes]:
    """The two frames of `body` as sent on the bus: topic and msgpack envelope."""
    env = {
        "v": SCHEMA_VERSION,
        "id": msg_id or new_id(),
        "ts": time.time(),
        "src": src,
        "inc": inc,
        "kind": body.kind,
        "body": _body_dict(body),
    }
    packer = getattr(_PACKERS, "packer", None)
    if packer is None:
        packer = _PACKERS.packer = msgpack.Packer(use_bin_type=True)
    return (topic or body.topic()).encode(), packer.pack(env)


# One msgpack Packer per thread: cheaper than a new one for every message.
_PACKERS = threading.local()


def _body_dict(body: Message) -> dict[str, Any]:
    fields: dict[str, Any] | None = getattr(body, "__dict__", None)
    if fields is not None and len(fields) == len(_schema(type(body)).names):
        return fields  # a dataclass instance's own map: exactly its fields, in order
    return {name: getattr(body, name) for name in _schema(type(body)).names}


# The envelope's keys and the exact types each may have (bool is not an int here).
_ENVELOPE_FIELDS: dict[str, tuple[type, ...]] = {
    "v": (int,), "id": (str,), "ts": (float, int), "src": (str,), "inc": (int,),
    "kind": (str,), "body": (dict,),
}


def decode(topic: bytes, payload: bytes | bytearray | memoryview) -> Envelope:
    """Validate and decode one bus message; anything malformed raises DecodeError."""
    try:
        topic_text = bytes(topic).decode("utf-8")
    except UnicodeDecodeError as exc:
        raise DecodeError("topic is not UTF-8") from exc
    try:
        env = msgpack.unpackb(payload, raw=False, strict_map_key=True, ext_hook=_no_ext)
    except DecodeError as exc:
        raise DecodeError(exc.reason, topic=topic_text) from None
    except UnicodeDecodeError as exc:
        raise DecodeError("a string is not UTF-8", topic=topic_text) from exc
    except Exception as exc:  # msgpack raises many types for garbage input
        raise DecodeError(f"not msgpack: {exc.__class__.__name__}", topic=topic_text) from exc
    try:
        return _envelope(topic_text, env)
    except DecodeError as exc:
        raise DecodeError(exc.reason, topic=topic_text) from None
    except RecursionError:
        raise DecodeError("message nested too deeply", topic=topic_text) from None


def _no_ext(code: int, data: bytes) -> Any:
    raise DecodeError(f"msgpack extension type {code} is not allowed")


def _envelope(topic: str, env: Any) -> Envelope:
    if type(env) is not dict:
        raise DecodeError("envelope is not a map")
    try:
        version, kind, ts = env["v"], env["kind"], env["ts"]
        well_typed = (
            len(env) == len(_ENVELOPE_FIELDS) and type(version) is int
            and type(env["id"]) is str and (type(ts) is float or type(ts) is int)
            and type(env["src"]) is str and type(env["inc"]) is int and type(kind) is str
            and type(env["body"]) is dict
        )
    except KeyError:
        well_typed = False
    if not well_typed:
        _envelope_fault(env)
    if version != SCHEMA_VERSION:
        raise DecodeError(f"schema version {version} is not {SCHEMA_VERSION}")
    cls = KINDS.get(kind)
    if cls is None:
        raise DecodeError(f"unknown kind {kind!r}")
    body = build(cls, env["body"])
    expected = body.topic()
    if topic != expected and not topic.startswith(expected + "."):
        raise DecodeError(f"kind {cls.kind!r} does not belong on this topic")
    # Validated above; fill the frozen dataclass directly (its __init__ costs twice as much).
    result: Envelope = object.__new__(Envelope)
    result.__dict__.update(topic=topic, id=env["id"], ts=float(env["ts"]), src=env["src"],
                           inc=env["inc"], body=body, v=SCHEMA_VERSION)
    return result


def _envelope_fault(env: dict[Any, Any]) -> typing.NoReturn:
    """Raise DecodeError naming what is wrong with an envelope's keys or types."""
    extra = sorted(map(str, set(env) - set(_ENVELOPE_FIELDS)))
    if extra:
        raise DecodeError(f"envelope has unknown key(s) {extra}")
    for key, types_ in _ENVELOPE_FIELDS.items():
        if key not in env:
            raise DecodeError(f"envelope lacks {key!r}")
        if type(env[key]) not in types_:
            raise DecodeError(f"envelope {key!r} has type {type(env[key]).__name__}")
    raise AssertionError("envelope fault not found")  # pragma: no cover


_M = typing.TypeVar("_M", bound=Message)


def build(cls: type[_M], fields: dict[str, Any]) -> _M:
    """Build and validate a message of type `cls` from a field map (DecodeError if bad)."""
    schema = _schema(cls)
    if type(fields) is not dict:
        raise DecodeError(f"{cls.kind}: body is not a map")
    checks = schema.checks
    for name, value in fields.items():
        check = checks.get(name)
        if check is None:
            extra = sorted(map(str, set(fields) - set(checks)))
            raise DecodeError(f"{cls.kind}: unknown field(s) {extra}")
        if not check(value):
            raise DecodeError(f"{cls.kind}: field {name!r} has type {type(value).__name__}")
    if len(fields) == len(checks) and schema.plain_init:
        # Every field present and type-checked: fill the frozen instance directly.
        msg: _M = object.__new__(cls)
        msg.__dict__.update(fields)
    else:
        for name in schema.required:
            if name not in fields:
                raise DecodeError(f"{cls.kind}: missing field {name!r}")
        msg = cls(**fields)
    msg.validate()
    return msg


Check = typing.Callable[[Any], bool]


@dataclass(frozen=True)
class _Schema:
    """A message class's field names, required fields and one type check per field."""

    names: tuple[str, ...]
    required: frozenset[str]
    checks: dict[str, Check]
    plain_init: bool  # __init__ only stores the fields (no __post_init__)


_SCHEMAS: dict[type, _Schema] = {}


def _schema(cls: type) -> _Schema:
    schema = _SCHEMAS.get(cls)
    if schema is None:
        hints = typing.get_type_hints(cls)
        fields = dataclasses.fields(cls)
        schema = _Schema(
            names=tuple(f.name for f in fields),
            required=frozenset(
                f.name for f in fields
                if f.default is dataclasses.MISSING and f.default_factory is dataclasses.MISSING
            ),
            checks={f.name: _checker(hints[f.name]) for f in fields},
            plain_init=not hasattr(cls, "__post_init__"),
        )
        _SCHEMAS[cls] = schema
    return schema


def _checker(hint: Any) -> Check:
    """A fast type check for one field's type hint."""
    if hint is Any:
        return _plain
    if hint is bool:
        return lambda v: v is True or v is False
    if hint is int:
        return lambda v: type(v) is int
    if hint is float:
        return lambda v: type(v) is float or type(v) is int
    if hint is str:
        return lambda v: type(v) is str
    if hint is type(None):
        return lambda v: v is None
    origin = typing.get_origin(hint)
    if origin in (Union, types.UnionType):
        alternatives = [_checker(h) for h in typing.get_args(hint)]
        return lambda v: any(check(v) for check in alternatives)
    if origin is list:
        (item_hint,) = typing.get_args(hint)
        item = _checker(item_hint)
        return lambda v: type(v) is list and all(item(x) for x in v)
    if origin is dict:
        key_hint, value_hint = typing.get_args(hint)
        if key_hint is str and value_hint is Any:
            return _plain_map
        key, value = _checker(key_hint), _checker(value_hint)
        return lambda v: type(v) is dict and all(key(k) and value(x) for k, x in v.items())
    raise TypeError(f"no bus type check for {hint!r}")


_SCALARS = frozenset({str, int, float, bool, bytes, type(None)})


def _plain_map(value: Any) -> bool:
    """Whether `value` is a str-keyed map of plain data (the common telemetry shape)."""
    if type(value) is not dict:
        return False
    for k, v in value.items():
        if type(k) is not str or (type(v) not in _SCALARS and not _plain(v)):
            return False
    return True


def _plain(value: Any) -> bool:
    """Whether `value` is plain msgpack data: scalars, lists, str-keyed maps (no recursion)."""
    if type(value) in _SCALARS:
        return True
    stack = [value]
    while stack:
        item = stack.pop()
        kind = type(item)
        if kind is list:
            stack.extend(item)
        elif kind is dict:
            for k, v in item.items():
                if type(k) is not str:
                    return False
                stack.append(v)
        elif kind not in _SCALARS:
            return False
    return True


def _nonempty(value: str, name: str) -> None:
    if not value:
        raise DecodeError(f"field {name!r} is empty")
