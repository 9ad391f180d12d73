"""A project's operator commands and goals: the `[operator]` table of project.toml.

The operator steers the mission through the agent, never around it: adding an area,
cancelling a goal, changing a priority, teleop, "all robots hold" are events the
project's events manager turns into percepts, exactly as its own operator UI does
(projects/wildfire/operator_console.py). The dashboard's mission panel sends them the
same way: JSON on the project's MQTT broker, sent again until the events manager
answers on `<topic>/reply` (`mrss.api.request_json`). A project declares which of the
commands it has and on which topic, and how its agent's beliefs name its goals:

    [operator]
    area = "mrss/ui/area"            # {"goal", "center": [lat, lon], "radius", "priority"}
    cancel = "mrss/ui/cancel"        # {"goal"}
    priority = "mrss/ui/priority"    # {"goal", "priority"}
    teleop = "mrss/ui/teleop"        # {"robot", "on"}
    hold = "mrss/ui/hold"            # {"on"}: every robot holds (true) or goes on (false)

    [operator.goals]                 # belief patterns: Goal, and Robot / Priority if known
    queued = "queued(Robot, Goal, Priority, _)"
    running = "task(Robot, Goal, Priority)"
    suspended = "waiting(Robot, Goal, Priority)"
    failed = "failed_goal(Goal)"
    done = "done_goal(Goal)"         # optional: said by the agent rather than inferred
    cancelled = "cancelled_goal(Goal)"
    refused = "refused(Goal, Why)"   # optional: the agent would not take it on, and why

    [operator.commands.NAME]         # the project's own commands with forms
                                     # (mrss.config.operator_declarations)

A pattern may name `Why` (the reason the agent gives): the mission panel shows it, and
a failed goal's alert says it.

`mrss check` validates the table (`mrss.check.operator`). Nothing here knows Textual.
"""

from __future__ import annotations

import difflib
from collections.abc import Callable, Mapping
from dataclasses import dataclass, field
from enum import StrEnum
from typing import TYPE_CHECKING, Any

from mrss.config.operator_commands import CommandSpec
from mrss.config.operator_declarations import COMMANDS_KEY, command_topic, read_commands
from mrss.errors import ConfigError

if TYPE_CHECKING:
    from mrss.agentspeak.terms import Struct

SECTION = "operator"


class OperatorCommand(StrEnum):
    """The operator commands a project may declare (the keys of `[operator]`)."""

    AREA = "area"
    CANCEL = "cancel"
    PRIORITY = "priority"
    TELEOP = "teleop"
    HOLD = "hold"


class GoalState(StrEnum):
    """Where a goal stands, as the mission panel shows it."""

    QUEUED = "queued"
    RUNNING = "running"
    SUSPENDED = "suspended"
    FAILED = "failed"
    DONE = "done"
    CANCELLED = "cancelled"
    REFUSED = "refused"

    @property
    def ended(self) -> bool:
        return self in (GoalState.FAILED, GoalState.DONE, GoalState.CANCELLED,
                        GoalState.REFUSED)


#: The states a project reads from its agent's beliefs (the keys of `[operator.goals]`).
#: A goal that leaves every declared one has ended: the dashboard then infers how
#: (`mrss.tui.models.goals`), so a project that wants "done" and "cancelled" said, not
#: guessed, declares those two patterns as well.
BELIEF_STATES = (GoalState.QUEUED, GoalState.RUNNING, GoalState.SUSPENDED, GoalState.FAILED,
                 GoalState.DONE, GoalState.CANCELLED, GoalState.REFUSED)
GOAL_VARS = ("Goal", "Robot", "Priority", "Why")


@dataclass(frozen=True)
class GoalPattern:
    """`task(Robot, Goal, Priority)`: which argument is the goal, the robot, the priority."""

    text: str
    functor: str
    arity: int
    positions: dict[str, int]  # "Goal" / "Robot" / "Priority" / "Why" -> argument index

    def match(self, belief: Struct) -> dict[str, Any] | None:
        """The named arguments of a belief of this pattern's predicate, else None."""
        if belief.functor != self.functor or len(belief.args) != self.arity or belief.neg:
            return None
        return {name: belief.args[i] for name, i in self.positions.items()}


def parse_pattern(text: str) -> GoalPattern:
    """A goal pattern; ValueError saying what is wrong. (The AgentSpeak parser is
    imported here, not with this module: the root supervisor reads the operator's
    topics and never a pattern, and the parser is megabytes it would hold all run.)"""
    from mrss.agentspeak import AslSyntaxError, parse_literal
    from mrss.agentspeak.terms import Var

    try:
        literal = parse_literal(text)
    except (AslSyntaxError, AssertionError, ValueError, RecursionError) as exc:
        raise ValueError(f"not a belief pattern: {text!r} ({str(exc).splitlines()[0]})") \
            from None
    positions: dict[str, int] = {}
    for i, arg in enumerate(literal.args):
        if isinstance(arg, Var) and arg.name in GOAL_VARS:
            positions[arg.name] = i
    if "Goal" not in positions:
        raise ValueError(f"{text!r} names no Goal variable (e.g. task(Robot, Goal, Priority))")
    return GoalPattern(text, literal.functor, len(literal.args), positions)


@dataclass(frozen=True)
class OperatorConfig:
    """The operator commands a project has (topic of each) and its goal patterns."""

    topics: dict[OperatorCommand, str] = field(default_factory=dict)
    goals: dict[GoalState, GoalPattern] = field(default_factory=dict)
    commands: dict[str, CommandSpec] = field(default_factory=dict)  # the project's own

    def has(self, command: OperatorCommand) -> bool:
        return command in self.topics


def read_operator(section: Any, *, file: str = "") -> OperatorConfig:
    """The `[operator]` table (absent: no commands, no goals); ConfigError naming the key."""
    if section is None:
        return OperatorConfig()
    if not isinstance(section, Mapping):
        raise ConfigError("must be a table", file=file, key=SECTION)
    topics: dict[OperatorCommand, str] = {}
    goals: dict[GoalState, GoalPattern] = {}
    commands: dict[str, CommandSpec] = {}
    known = [c.value for c in OperatorCommand] + ["goals", COMMANDS_KEY]
    for key, value in section.items():
        where = f"{SECTION}.{key}"
        if key == "goals":
            goals = _goals(value, file)
        elif key == COMMANDS_KEY:
            commands = read_commands(value, file=file, section=SECTION)
        elif key in OperatorCommand.__members__.values():
            if not isinstance(value, str) or not value.strip() or any(c in value for c in "#+"):
                raise ConfigError("must be an MQTT topic (no wildcards)", file=file, key=where)
            topics[OperatorCommand(key)] = value.strip()
        else:
            raise ConfigError(f"unknown key{_hint(key, known)}", file=file, key=where)
    return OperatorConfig(topics, goals, commands)


def operator_topics(section: Any) -> list[str]:
    """The MQTT topics of the `[operator]` table's commands, built-in and declared, read
    without checking the rest (the goal patterns, the commands' percepts): for the root
    supervisor's incident recorder, in a project `read_operator` has accepted (`mrss
    check`, the start's check). It leaves the AgentSpeak parser unimported."""
    if not isinstance(section, Mapping):
        return []
    topics = [value.strip() for key, value in section.items()
              if key in OperatorCommand.__members__.values() and isinstance(value, str)]
    declared = section.get(COMMANDS_KEY)
    if isinstance(declared, Mapping):
        topics += [command_topic(name, table) for name, table in declared.items()
                   if isinstance(table, Mapping)]
    return topics


def _goals(value: Any, file: str) -> dict[GoalState, GoalPattern]:
    if not isinstance(value, Mapping):
        raise ConfigError("must be a table", file=file, key=f"{SECTION}.goals")
    goals: dict[GoalState, GoalPattern] = {}
    known = [s.value for s in BELIEF_STATES]
    for key, text in value.items():
        where = f"{SECTION}.goals.{key}"
        if key not in known:
            raise ConfigError(f"unknown goal state{_hint(key, known)}", file=file, key=where)
        if not isinstance(text, str):
            raise ConfigError("must be a belief pattern such as \"task(Robot, Goal, Priority)\"",
                              file=file, key=where)
        try:
            goals[GoalState(key)] = parse_pattern(text)
        except ValueError as exc:
            raise ConfigError(str(exc), file=file, key=where) from None
    return goals


def _hint(word: str, known: list[str]) -> str:
    close = difflib.get_close_matches(word, known, n=1)
    hint = f"; did you mean {close[0]!r}?" if close else ""
    return f" {word!r}{hint} (known: {', '.join(known)})"


# -- the payloads (what the events manager reads; projects/wildfire/events.py) -----------

class PayloadError(ValueError):
    """Operator input that cannot be sent; the text says what to fix, `field` where."""

    def __init__(self, message: str, field_name: str | None = None) -> None:
        super().__init__(message)
        self.field = field_name


def _ident(value: str, what: str) -> str:
    text = value.strip()
    if not text or not (text[0].islower() and text.replace("_", "a").isalnum()):
        raise PayloadError(f"{what} must be a lowercase identifier (a1, north_field), "
                           f"not {value!r}", what)
    return text


def _center(text: str) -> list[float]:
    try:
        lat, lon = (float(v) for v in text.replace(" ", "").split(","))
    except ValueError:
        raise PayloadError(f"centre must be LAT,LON (e.g. -35.3606,149.1652), not {text!r}",
                           "center") from None
    if not (-90 <= lat <= 90 and -180 <= lon <= 180):
        raise PayloadError(f"centre {lat}, {lon} is not a position", "center")
    return [lat, lon]


def _radius(text: str) -> float:
    try:
        metres = float(text)
    except ValueError:
        raise PayloadError(f"radius must be metres, not {text!r}", "radius") from None
    if not metres > 0:
        raise PayloadError("radius must be more than 0 m", "radius")
    return metres


def priority_value(text: str) -> int:
    try:
        return int(text.strip())
    except ValueError:
        raise PayloadError(f"priority must be a whole number, not {text!r}",
                           "priority") from None


# Each field of an area and its check (the text in, the value or a PayloadError out).
AREA_FIELDS: dict[str, Callable[[str], Any]] = {
    "name": lambda text: _ident(text, "name"), "center": _center, "radius": _radius,
    "priority": priority_value}


def area_payload(name: str, center: str, radius: str, priority: str) -> dict[str, Any]:
    """An area from the form's text fields; PayloadError naming the field."""
    texts = {"name": name, "center": center, "radius": radius, "priority": priority}
    value = {key: check(texts[key]) for key, check in AREA_FIELDS.items()}
    return {"goal": value["name"], "center": value["center"], "radius": value["radius"],
            "priority": value["priority"]}


def cancel_payload(goal: str) -> dict[str, Any]:
    return {"goal": _ident(goal, "goal")}


def priority_payload(goal: str, priority: str) -> dict[str, Any]:
    return {"goal": _ident(goal, "goal"), "priority": priority_value(priority)}


def teleop_payload(robot: str, on: bool) -> dict[str, Any]:
    return {"robot": _ident(robot, "robot"), "on": on}


def hold_payload(on: bool) -> dict[str, Any]:
    return {"on": on}
