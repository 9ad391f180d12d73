"""Reading `[operator.commands.NAME]` of project.toml into `CommandSpec`s.

Every mistake is a ConfigError naming the key (`operator.commands.NAME.fields`, ...),
with "did you mean" for a misspelt key, type, role or field; `mrss check` adds the line.
What a command is and how its values are checked: `mrss.config.operator_commands`.
"""

from __future__ import annotations

from collections.abc import Mapping
from typing import Any

from mrss.agentspeak import AslSyntaxError, parse_literal
from mrss.agentspeak.terms import Struct, Var
from mrss.config.operator_commands import (
    DEFAULT_MAX_VERTICES,
    HARD_MAX_VERTICES,
    CommandSpec,
    FieldSpec,
    FieldType,
    did_you_mean,
    identifier,
)
from mrss.errors import ConfigError

COMMANDS_KEY = "commands"
DEFAULT_TOPIC_PREFIX = "mrss/operator"
COMMAND_KEYS = ("label", "percept", "role", "topic", "fields", "goal")
FIELD_KEYS = ("name", "type", "label", "units", "default", "min", "max", "integer",
              "choices", "atom", "max_vertices")
ROLES = ("commander", "operator", "observer")


def default_topic(name: str) -> str:
    """The topic of command `name` when its table names none."""
    return f"{DEFAULT_TOPIC_PREFIX}/{name}"


def command_topic(name: str, table: Mapping[str, Any]) -> str:
    """The topic of command `name`, its table not checked (a table `read_commands` took)."""
    topic = table.get("topic")
    return topic.strip() if isinstance(topic, str) else default_topic(name)


def read_commands(value: Any, *, file: str = "",
                  section: str = "operator") -> dict[str, CommandSpec]:
    """`[operator.commands]`: every command, or ConfigError naming the key at fault."""
    where = f"{section}.{COMMANDS_KEY}"
    if not isinstance(value, Mapping):
        raise ConfigError("must be a table of commands ([operator.commands.NAME])",
                          file=file, key=where)
    commands: dict[str, CommandSpec] = {}
    for name, table in value.items():
        commands[name] = _command(name, table, file, f"{where}.{name}")
    topics = [c.topic for c in commands.values()]
    for spec in commands.values():
        if topics.count(spec.topic) > 1:
            raise ConfigError(f"topic {spec.topic!r} is used by two commands", file=file,
                              key=f"{where}.{spec.name}.topic")
    return commands


def _command(name: str, table: Any, file: str, where: str) -> CommandSpec:
    if not identifier(name):
        raise ConfigError(f"command name {name!r} must be a lowercase identifier",
                          file=file, key=where)
    if not isinstance(table, Mapping):
        raise ConfigError("must be a table (label, percept, role, fields)", file=file,
                          key=where)
    for key in table:
        if key not in COMMAND_KEYS:
            raise ConfigError(f"unknown key {key!r}{did_you_mean(key, COMMAND_KEYS)} "
                              f"(known: {', '.join(COMMAND_KEYS)})", file=file,
                              key=f"{where}.{key}")
    percept = table.get("percept")
    if not isinstance(percept, str):
        raise ConfigError("must say the percept it becomes, e.g. "
                          "\"exclusion_zone(Zone, Shape)\"", file=file, key=f"{where}.percept")
    try:
        literal = parse_literal(percept)
    except (AslSyntaxError, AssertionError, ValueError, RecursionError):
        raise ConfigError(f"not a percept pattern: {percept!r}", file=file,
                          key=f"{where}.percept") from None
    raw_fields = table.get("fields", [])
    if not isinstance(raw_fields, list):
        raise ConfigError("must be a list of fields ({ name = ..., type = ... })",
                          file=file, key=f"{where}.fields")
    fields = tuple(_field(f, file, f"{where}.fields", i) for i, f in enumerate(raw_fields))
    names = [f.name for f in fields]
    for dup in {n for n in names if names.count(n) > 1}:
        raise ConfigError(f"field {dup!r} is declared twice", file=file, key=f"{where}.fields")
    variables = {f.variable: f for f in fields}
    used = set()
    for arg in literal.args:
        if isinstance(arg, Var):
            if arg.name not in variables:
                known = ", ".join(variables) or "none"
                raise ConfigError(f"{arg.name} is no field of the command (fields as "
                                  f"variables: {known}){did_you_mean(arg.name, list(variables))}",
                                  file=file, key=f"{where}.percept")
            used.add(arg.name)
        elif isinstance(arg, Struct) and not arg.ground:
            raise ConfigError("field variables go directly as arguments "
                              "(exclusion_zone(Zone, Shape))", file=file, key=f"{where}.percept")
    for spec in fields:
        if spec.variable not in used:
            raise ConfigError(f"field {spec.name!r} is not in the percept (as {spec.variable})",
                              file=file, key=f"{where}.percept")
    role = table.get("role", "operator")
    if role not in ROLES:
        raise ConfigError(f"role {role!r} is not one of {', '.join(ROLES)}"
                          f"{did_you_mean(str(role), ROLES)}", file=file, key=f"{where}.role")
    topic = table.get("topic", default_topic(name))
    if not isinstance(topic, str) or not topic.strip() or any(c in topic for c in "#+"):
        raise ConfigError("must be an MQTT topic (no wildcards)", file=file, key=f"{where}.topic")
    goal = table.get("goal", "")
    if goal and goal not in names:
        raise ConfigError(f"goal names no field{did_you_mean(str(goal), names)} "
                          f"(fields: {', '.join(names)})", file=file, key=f"{where}.goal")
    label = table.get("label", "")
    if not isinstance(label, str):
        raise ConfigError("must be text", file=file, key=f"{where}.label")
    return CommandSpec(name, percept, fields, topic.strip(), label, str(role), str(goal),
                       literal.functor, len(literal.args))


def _field(raw: Any, file: str, where: str, index: int) -> FieldSpec:
    if not isinstance(raw, Mapping):
        raise ConfigError(f"field {index + 1} must be a table {{ name = ..., type = ... }}",
                          file=file, key=where)
    for key in raw:
        if key not in FIELD_KEYS:
            raise ConfigError(f"field {index + 1}: unknown key {key!r}"
                              f"{did_you_mean(key, FIELD_KEYS)} (known: {', '.join(FIELD_KEYS)})",
                              file=file, key=where)
    name = raw.get("name")
    if not isinstance(name, str) or not identifier(name):
        raise ConfigError(f"field {index + 1}: name must be a lowercase identifier",
                          file=file, key=where)
    kind = raw.get("type")
    types = [t.value for t in FieldType]
    if kind not in types:
        raise ConfigError(f"field {name!r}: type {kind!r} is not one of {', '.join(types)}"
                          f"{did_you_mean(str(kind), types)}", file=file, key=where)
    try:
        spec = FieldSpec(
            name, FieldType(kind), label=str(raw.get("label", "")), units=str(raw.get("units", "")),
            minimum=_opt_number(raw.get("min"), "min"), maximum=_opt_number(raw.get("max"), "max"),
            integer=_flag(raw.get("integer", False), "integer"),
            choices=tuple(_choices(raw.get("choices", []))),
            atom=_flag(raw.get("atom", False), "atom"),
            max_vertices=_vertices(raw.get("max_vertices", DEFAULT_MAX_VERTICES)))
        if spec.type is FieldType.CHOICE and not spec.choices:
            raise ValueError("a choice needs choices = [\"a\", \"b\"]")
        if spec.minimum is not None and spec.maximum is not None and spec.minimum > spec.maximum:
            raise ValueError(f"min {spec.minimum:g} is above max {spec.maximum:g}")
        default = raw.get("default")
        if default is not None:
            default = spec.check(_default_json(spec, default))
            spec = FieldSpec(**{**spec.__dict__, "default": _default_back(spec, default)})
    except (ValueError, TypeError) as exc:
        raise ConfigError(f"field {name!r}: {exc}", file=file, key=where) from None
    return spec


def _default_json(spec: FieldSpec, value: Any) -> Any:
    """TOML defaults are written plainly: a circle as [lat, lon, radius]."""
    if spec.type is FieldType.CIRCLE and isinstance(value, list) and len(value) == 3:
        return {"center": value[:2], "radius": value[2]}
    return value


def _default_back(spec: FieldSpec, value: Any) -> Any:
    if spec.type is FieldType.CIRCLE:
        return [*value["center"], value["radius"]]
    return value


def _opt_number(value: Any, key: str) -> float | None:
    if value is None:
        return None
    if isinstance(value, bool) or not isinstance(value, (int, float)):
        raise ValueError(f"{key} must be a number")
    return float(value)


def _flag(value: Any, key: str) -> bool:
    if not isinstance(value, bool):
        raise ValueError(f"{key} must be true or false")
    return value


def _choices(value: Any) -> list[str]:
    if not isinstance(value, list) or not all(isinstance(c, str) and identifier(c)
                                              for c in value):
        raise ValueError("choices must be a list of lowercase identifiers")
    return value


def _vertices(value: Any) -> int:
    if isinstance(value, bool) or not isinstance(value, int) or not 3 <= value <= HARD_MAX_VERTICES:
        raise ValueError(f"max_vertices must be a whole number in [3, {HARD_MAX_VERTICES}]")
    return value
