"""The one validation layer for data that comes from a robot or from outside MRSS.

Everything a robot reports (a link's telemetry record, a project's `publish_data`, a
`robot.<id>.data` bus message) and every outside payload field is checked against a
declaration (mrss.edge.record_declarations) before anything acts on it:

- **who**: the robot id must be a configured robot (`RecordValidator.robots`);
- **what**: each record type (`RECORDS`) declares its fields: kind, whether it is
  required, and its range: a fixed one or a physical limit of the robot's type
  (`Limits`), with defaults per robot type that project.toml may override
  (`limit_overrides` reads the `[datalayer]` `*_range` options, docs/config.md);
- **how much**: fields a declaration does not list (and record types it does not know)
  must still be plain bounded data (`plain`): finite numbers, integers within
  +-2**53, strings up to `MAX_TEXT` characters, lists up to `MAX_ITEMS`, nesting up to
  `MAX_DEPTH`.

A value that does not fit raises `Rejected` with a short `reason` (stable, for counting:
"unknown robot", "position.lat out of range") and a `detail` for the log. Nothing here
logs: `mrss.edge.rejections.RejectionLog` counts and logs what callers refuse.
"""

from __future__ import annotations

import math
import sys
from collections.abc import Iterable, Mapping
from typing import Any

from mrss.edge.record_declarations import (
    COMMON,
    DEFAULT_LIMITS,
    LIMIT_NAMES,
    MAX_DEPTH,
    MAX_ID,
    MAX_INT,
    MAX_ITEMS,
    MAX_TEXT,
    RECORDS,
    FieldKind,
    Limits,
    Range,
    RobotType,
    Spec,
)


class Rejected(ValueError):
    """A value that does not fit its declaration: `reason` to count, `detail` to read."""

    def __init__(self, reason: str, detail: str = "") -> None:
        super().__init__(f"{reason}: {detail}" if detail else reason)
        self.reason = reason
        self.detail = detail



# ---------------------------------------------------------------------- primitives
def number(value: Any, where: str = "value", bound: Range | None = None) -> float | int:
    """A finite number (bool is not one), within `bound` when given; Rejected otherwise.
    Integers are held to +-MAX_INT, so no later float() overflows."""
    if isinstance(value, bool) or not isinstance(value, int | float):
        raise Rejected(f"{where} not a number", f"got {type(value).__name__}")
    if isinstance(value, int) and not -MAX_INT <= value <= MAX_INT:
        raise Rejected(f"{where} out of range", f"an integer of {len(str(abs(value)))} digits")
    if isinstance(value, float) and not math.isfinite(value):
        raise Rejected(f"{where} not finite", repr(value))
    if bound is not None and value not in bound:
        raise Rejected(f"{where} out of range", f"{value!r} not in {bound}")
    return value


def integer(value: Any, where: str = "value", bound: Range | None = None) -> int:
    """A bounded integer (not a bool); Rejected otherwise."""
    if isinstance(value, bool) or not isinstance(value, int):
        raise Rejected(f"{where} not an integer", f"got {type(value).__name__}")
    number(value, where, bound)
    return value


def text(value: Any, where: str = "value", max_length: int = MAX_TEXT) -> str:
    """A string of at most `max_length` characters; Rejected otherwise."""
    if not isinstance(value, str):
        raise Rejected(f"{where} not a string", f"got {type(value).__name__}")
    if len(value) > max_length:
        raise Rejected(f"{where} too long", f"{len(value)} characters > {max_length}")
    return value


def plain(value: Any, where: str = "value", depth: int = 0) -> Any:
    """Plain bounded data (None, flags, numbers, strings, lists, string-keyed objects)."""
    if depth > MAX_DEPTH:
        raise Rejected(f"{where} nested too deeply", f"more than {MAX_DEPTH} levels")
    if value is None or isinstance(value, bool):
        return value
    if isinstance(value, int | float):
        return number(value, where)
    if isinstance(value, str):
        return text(value, where)
    if isinstance(value, list | tuple):
        _count(value, where)
        return [plain(v, where, depth + 1) for v in value]
    if isinstance(value, Mapping):
        _count(value, where)
        return {text(k, f"{where} key", MAX_TEXT): plain(v, where, depth + 1)
                for k, v in value.items()}
    raise Rejected(f"{where} not plain data", f"a {type(value).__name__}")


def _count(items: Iterable[Any] | Mapping[str, Any], where: str) -> None:
    size = len(items)  # type: ignore[arg-type]
    if size > MAX_ITEMS:
        raise Rejected(f"{where} too many items", f"{size} > {MAX_ITEMS}")


def robot_id(value: Any) -> str:
    """A robot id's shape: a non-empty string of at most MAX_ID characters."""
    ident = text(value, "robot id", MAX_ID)
    if not ident:
        raise Rejected("robot id empty")
    return ident


def _field(spec: Spec, value: Any, where: str, limits: Limits) -> None:
    if value is None and not spec.required:
        return
    bound = getattr(limits, spec.bound) if isinstance(spec.bound, str) else spec.bound
    if spec.kind is FieldKind.NUMBER:
        number(value, where, bound)
    elif spec.kind is FieldKind.INT:
        integer(value, where, bound)
    elif spec.kind is FieldKind.TEXT:
        text(value, where)
    elif not isinstance(value, bool):
        raise Rejected(f"{where} not true or false", f"got {type(value).__name__}")


def check_record(record: Any, limits: Limits) -> dict[str, Any]:
    """One telemetry record checked against its type's declaration (`RECORDS`); a type
    not declared there is checked as plain bounded data. Returns the record."""
    if type(record) is dict and _fits(record, limits):
        return dict(record)
    if not isinstance(record, Mapping):
        raise Rejected("record not an object", f"a {type(record).__name__}")
    _count(record, "record")
    kind = record.get("type")
    declared = RECORDS.get(kind, {}) if isinstance(kind, str) else {}
    name = kind if isinstance(kind, str) and kind in RECORDS else "record"
    for key, wanted in declared.items():
        if wanted.required and key not in record:
            raise Rejected(f"{name}.{key} missing")
    for key, value in record.items():
        key = text(key, "record key", 64)
        spec: Spec | None = declared.get(key) or COMMON.get(key)
        if spec is None:
            plain(value, f"{name}.{key}", 1)
        else:
            _field(spec, value, f"{name}.{key}", limits)
    return dict(record)


# ------------------------------------------------------- the fast path of check_record
# A field as the fast path checks it: kind code, low, high, required. Numbers of no
# declared range get the finite floats as their range, so inf and NaN never fit.
_FastSpec = tuple[int, float, float, bool]
_FastTable = tuple[dict[str, _FastSpec], tuple[str, ...]]  # fields, required keys
_NUMBER, _INT, _TEXT, _FLAG = range(4)
_CODES = {FieldKind.NUMBER: _NUMBER, FieldKind.INT: _INT, FieldKind.TEXT: _TEXT,
          FieldKind.FLAG: _FLAG}
_FINITE = sys.float_info.max
#: id(limits) -> (limits, table of each declared type, table of the other types)
_FAST: dict[int, tuple[Limits, dict[str, _FastTable], _FastTable]] = {}
_FAST_KEEP = 1024  # Limits objects remembered (then the cache starts again)


def _fast_table(declared: Mapping[str, Spec], limits: Limits) -> _FastTable:
    specs: dict[str, _FastSpec] = {}
    for key, spec in (*COMMON.items(), *declared.items()):  # declared wins, as there
        bound = getattr(limits, spec.bound) if isinstance(spec.bound, str) else spec.bound
        low = -_FINITE if bound is None else max(float(bound.low), -_FINITE)
        high = _FINITE if bound is None else min(float(bound.high), _FINITE)
        specs[key] = (_CODES[spec.kind], low, high, spec.required)
    return specs, tuple(key for key, spec in declared.items() if spec.required)


def _compiled(limits: Limits) -> tuple[Limits, dict[str, _FastTable], _FastTable]:
    entry = _FAST.get(id(limits))
    if entry is None or entry[0] is not limits:
        if len(_FAST) >= _FAST_KEEP:
            _FAST.clear()
        entry = (limits, {kind: _fast_table(declared, limits)
                          for kind, declared in RECORDS.items()}, _fast_table({}, limits))
        _FAST[id(limits)] = entry
    return entry


def _fits(record: dict[str, Any], limits: Limits) -> bool:
    """Whether `record` certainly passes `check_record`: a quick look at the common,
    well-formed record (declared or common fields only, each of its exact type within
    its range). False means "not sure": the full check then accepts it or says why not."""
    kind = record.get("type")
    if type(kind) is not str or len(record) > MAX_ITEMS:
        return False
    _, tables, other = _compiled(limits)
    specs, required = tables.get(kind, other)
    for key in required:
        if key not in record:
            return False
    for key, value in record.items():
        spec = specs.get(key)
        if spec is None:
            return False
        code, low, high, needed = spec
        if value is None:
            if needed:
                return False
            continue
        kind_of = type(value)
        if code == _NUMBER:
            if kind_of is float:
                if not low <= value <= high:
                    return False
            elif kind_of is not int or not (-MAX_INT <= value <= MAX_INT
                                            and low <= value <= high):
                return False
        elif code == _INT:
            if kind_of is not int or not (-MAX_INT <= value <= MAX_INT
                                          and low <= value <= high):
                return False
        elif code == _TEXT:
            if kind_of is not str or len(value) > MAX_TEXT:
                return False
        elif kind_of is not bool:
            return False
    return True


class RecordValidator:
    """Checks robot data: a configured robot (when `robots` is given), a valid record.

    `limits` maps a robot id to its limits; a robot not in it gets `default`.
    """

    def __init__(self, robots: Iterable[str] | None = None, *,
                 limits: Mapping[str, Limits] | None = None,
                 default: Limits = DEFAULT_LIMITS[RobotType.GROUND]) -> None:
        self.robots = frozenset(robots) if robots is not None else None
        self.limits = dict(limits or {})
        self.default = default

    def check(self, robot: Any, record: Any) -> dict[str, Any]:
        """The record if `robot` may send it and it fits its declaration; Rejected else."""
        ident = robot_id(robot)
        if self.robots is not None and ident not in self.robots:
            raise Rejected("unknown robot", f"{ident!r} is not a configured robot")
        checked = check_record(record, self.limits.get(ident, self.default))
        sender = checked.get("robot")
        if sender is not None and sender != ident:
            raise Rejected("robot mismatch", f"record of {sender!r} sent as {ident!r}")
        return checked


def limit_overrides(section: Mapping[str, Any]) -> dict[str, list[float]]:
    """The `<limit>_range = [low, high]` keys of a `[datalayer]` table, by limit name;
    Rejected(reason=the key) for one that is not two finite numbers with low <= high."""
    overrides: dict[str, list[float]] = {}
    for name in LIMIT_NAMES:
        value = section.get(f"{name}_range")
        if value is None:
            continue
        if (not isinstance(value, list) or len(value) != 2
                or not all(isinstance(v, int | float) and not isinstance(v, bool)
                           and math.isfinite(v) for v in value) or value[0] > value[1]):
            raise Rejected(f"{name}_range", "must be [low, high], finite numbers, low <= high")
        overrides[name] = [float(value[0]), float(value[1])]
    return overrides
