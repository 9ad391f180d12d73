"""A project's own alert rules: the `[[alerts]]` array of tables of project.toml.

Each rule watches one telemetry field of the robots (as the dashboard's robot detail
names it: `record.key` for a typed link record, `key` for a flat one) and raises an
alert while the value is below `below` (or above `above`); it ends when the value is
back. The dashboard shows them with its built-in alerts (battery low, link down, ...):

    [[alerts]]
    name = "water low"          # the alert's name on the alerts strip and in the log
    field = "tank.level"        # {"type": "tank", "level": ..} records' level
    below = 50.0                # raised while level < 50 (and/or `above = ...`)
    robot = "ugv1"              # only this robot (default: every robot with the field)
    severity = "warning"        # or "severe" (red on the strip)

`read_alert_rules` reads the array (ConfigError naming `alerts[N].key`); `mrss check`
reports the same errors with their line (`mrss.check.alerts`). Nothing here knows Textual.
"""

from __future__ import annotations

import difflib
import math
from collections.abc import Mapping
from dataclasses import dataclass
from enum import StrEnum
from typing import Any

from mrss.errors import ConfigError

SECTION = "alerts"


class Severity(StrEnum):
    WARNING = "warning"
    SEVERE = "severe"


KEYS = ("name", "field", "below", "above", "robot", "severity")


@dataclass(frozen=True)
class AlertRule:
    """One rule: `name` while `field` of `robot` (any if "") is below/above a threshold."""

    name: str
    field: str
    below: float | None = None
    above: float | None = None
    robot: str = ""
    severity: Severity = Severity.WARNING

    @property
    def record(self) -> str:
        """The telemetry record type the field is in ("" for a flat record)."""
        return self.field.rpartition(".")[0]

    @property
    def key(self) -> str:
        return self.field.rpartition(".")[2]

    def value(self, data: Mapping[str, Any]) -> float | None:
        """The field's number in one telemetry record, or None if the record has none."""
        kind = data.get("type")
        if (kind or "") != self.record:
            return None
        value = data.get(self.key)
        if isinstance(value, bool) or not isinstance(value, (int, float)):
            return None
        return float(value) if math.isfinite(value) else None

    def on(self, value: float) -> bool:
        """Whether the alert's condition holds for `value`."""
        return ((self.below is not None and value < self.below)
                or (self.above is not None and value > self.above))

    def text(self, value: float) -> str:
        """`tank.level 31 < 50` (`tank.level 120` when the condition does not hold)."""
        if self.below is not None and value < self.below:
            return f"{self.field} {value:g} < {self.below:g}"
        if self.above is not None and value > self.above:
            return f"{self.field} {value:g} > {self.above:g}"
        return f"{self.field} {value:g}"


def read_alert_rules(value: Any, *, file: str = "") -> tuple[AlertRule, ...]:
    """The `[[alerts]]` rules (absent: none); ConfigError naming `alerts[N].key`."""
    if value is None:
        return ()
    if not isinstance(value, list):
        raise ConfigError("must be an array of tables: [[alerts]] name = ..., field = ...",
                          file=file, key=SECTION)
    rules: list[AlertRule] = []
    names: set[str] = set()
    for index, table in enumerate(value, start=1):
        rule = _rule(table, f"{SECTION}[{index}]", file)
        if rule.name in names:
            raise ConfigError(f"a second rule named {rule.name!r} (names must differ)",
                              file=file, key=f"{SECTION}[{index}].name")
        names.add(rule.name)
        rules.append(rule)
    return tuple(rules)


def _rule(table: Any, where: str, file: str) -> AlertRule:
    if not isinstance(table, Mapping):
        raise ConfigError("must be a table (name, field, below/above, robot, severity)",
                          file=file, key=where)
    for key in table:
        if key not in KEYS:
            raise ConfigError(f"unknown key {key!r}{_hint(key, KEYS)} (known: {', '.join(KEYS)})",
                              file=file, key=f"{where}.{key}")
    name = _text(table, "name", where, file, "the alert's name, e.g. \"water low\"")
    field = _text(table, "field", where, file,
                  "a telemetry field, e.g. \"tank.level\" (record.key) or \"battery\"")
    if field.startswith(".") or field.endswith(".") or " " in field:
        raise ConfigError(f"must be record.key or key (e.g. \"tank.level\"), not {field!r}",
                          file=file, key=f"{where}.field")
    below, above = _number(table, "below", where, file), _number(table, "above", where, file)
    if below is None and above is None:
        raise ConfigError("needs a threshold: below = N (raised while the value is under "
                          "N) or above = N", file=file, key=where)
    if below is not None and above is not None and below > above:
        raise ConfigError(f"below = {below:g} is over above = {above:g}: the alert would "
                          "always be on", file=file, key=f"{where}.below")
    robot = ""
    if "robot" in table:
        robot = _text(table, "robot", where, file, "a robot id, e.g. \"ugv1\"")
    severity = Severity.WARNING
    if "severity" in table:
        raw = table["severity"]
        known = [s.value for s in Severity]
        if raw not in known:
            raise ConfigError(f"must be one of {', '.join(known)}, not {raw!r}"
                              f"{_hint(str(raw), known)}", file=file, key=f"{where}.severity")
        severity = Severity(raw)
    return AlertRule(name, field, below, above, robot, severity)


def _text(table: Mapping[str, Any], key: str, where: str, file: str, what: str) -> str:
    value = table.get(key)
    if not isinstance(value, str) or not value.strip():
        problem = f"{key} is missing" if value is None else f"must be a text, not {value!r}"
        raise ConfigError(f"{problem}: {what}", file=file,
                          key=f"{where}.{key}" if key in table else where)
    return value.strip()


def _number(table: Mapping[str, Any], key: str, where: str, file: str) -> float | None:
    if key not in table:
        return None
    value = table[key]
    if isinstance(value, bool) or not isinstance(value, (int, float)) or not math.isfinite(value):
        raise ConfigError(f"must be a number, not {value!r}", file=file, key=f"{where}.{key}")
    return float(value)


def _hint(word: str, known: Any) -> str:
    close = difflib.get_close_matches(word, list(known), n=1)
    return f"; did you mean {close[0]!r}?" if close else ""


def project_alert_rules(sections: Mapping[str, Any], file: str = "") -> tuple[AlertRule, ...]:
    """The rules of a loaded project's tables (`ProjectConfig.sections`)."""
    return read_alert_rules(sections.get(SECTION), file=file)
