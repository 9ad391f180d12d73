"""What robot data may hold: the declarations the validation layer checks against.

Pure data, no checking (that is `mrss.edge.validation`):

- **what**: each record type (`RECORDS`) declares its fields (`Spec`): kind (number,
  integer, text, flag), whether it is required, and its range: a fixed one (latitude
  [-90, 90], longitude [-180, 180], battery [0, 100] %) or a physical limit of the
  robot's type (`Limits`: altitude, speeds, temperature, tank, voltage, current); `COMMON`
  declares the envelope fields every record may have;
- **whose limits**: the robot types (`RobotType`, by link kind: `LINK_TYPES`, and of a
  project's robots: `configured_robots`) and their default limits (`DEFAULT_LIMITS`),
  which project.toml may override (`[datalayer]` `*_range` options, docs/config.md);
- **how much**: the bounds of plain data (`MAX_TEXT`, `MAX_ITEMS`, `MAX_DEPTH`,
  `MAX_INT`, `MAX_ID`).
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass, fields, replace
from enum import Enum, StrEnum
from typing import Any

MAX_TEXT = 1024  # characters of one string
MAX_ITEMS = 256  # items of one list or object
MAX_DEPTH = 16  # nesting of lists and objects
MAX_INT = 2 ** 53  # integers are exact as JSON numbers within +-2**53
MAX_ID = 64  # characters of a robot id


class RobotType(StrEnum):
    """What kind of machine a robot is, for its physical limits."""

    AERIAL = "aerial"
    GROUND = "ground"


#: The robot type of each link kind (a copter speaks MAVLink; the UGV and HTTP robots
#: drive on the ground).
LINK_TYPES: dict[str, RobotType] = {"mavlink": RobotType.AERIAL, "mqtt": RobotType.GROUND,
                                    "http": RobotType.GROUND}


@dataclass(frozen=True)
class Range:
    """A closed interval of allowed values."""

    low: float
    high: float

    def __contains__(self, value: object) -> bool:
        return isinstance(value, int | float) and self.low <= value <= self.high

    def __str__(self) -> str:
        return f"[{self.low:g}, {self.high:g}]"


LAT = Range(-90.0, 90.0)
LON = Range(-180.0, 180.0)
PERCENT = Range(0.0, 100.0)
HEADING = Range(-360.0, 360.0)


@dataclass(frozen=True)
class Limits:
    """The physical ranges of one robot type (units: m, m/s, degrees C, L, V, A)."""

    alt: Range  # altitude above mean sea level
    relative_alt: Range  # altitude above home
    velocity: Range  # one component of the velocity (vx, vy, vz)
    speed: Range  # ground speed
    temperature: Range  # a sensed temperature (a hotspot's)
    tank: Range  # a tank's level and capacity
    voltage: Range
    current: Range

    def overridden(self, overrides: Mapping[str, Any]) -> Limits:
        """These limits with some replaced: name -> [low, high] (names: `LIMIT_NAMES`)."""
        changes = {name: Range(float(value[0]), float(value[1]))
                   for name, value in overrides.items() if value is not None}
        return replace(self, **changes)


LIMIT_NAMES = tuple(f.name for f in fields(Limits))

DEFAULT_LIMITS: dict[RobotType, Limits] = {
    RobotType.AERIAL: Limits(alt=Range(-500.0, 12_000.0), relative_alt=Range(-1_000.0, 12_000.0),
                             velocity=Range(-100.0, 100.0), speed=Range(0.0, 100.0),
                             temperature=Range(-100.0, 2_000.0), tank=Range(0.0, 10_000.0),
                             voltage=Range(0.0, 1_000.0), current=Range(-1_000.0, 1_000.0)),
    RobotType.GROUND: Limits(alt=Range(-500.0, 9_000.0), relative_alt=Range(-1_000.0, 9_000.0),
                             velocity=Range(-50.0, 50.0), speed=Range(0.0, 50.0),
                             temperature=Range(-100.0, 2_000.0), tank=Range(0.0, 100_000.0),
                             voltage=Range(0.0, 1_000.0), current=Range(-1_000.0, 1_000.0)),
}


class FieldKind(Enum):
    """What a declared field holds."""

    NUMBER = "number"
    INT = "int"
    TEXT = "text"
    FLAG = "flag"


@dataclass(frozen=True)
class Spec:
    """One declared field: its kind, its range (fixed, or a `Limits` name), and whether it
    must be there (a field that is not required may also be None: "unknown")."""

    kind: FieldKind
    bound: Range | str | None = None
    required: bool = False


def _num(bound: Range | str | None = None, required: bool = False) -> Spec:
    return Spec(FieldKind.NUMBER, bound, required)


def _int(bound: Range | str | None = None, required: bool = False) -> Spec:
    return Spec(FieldKind.INT, bound, required)


TEXT = Spec(FieldKind.TEXT)
FLAG = Spec(FieldKind.FLAG)

#: The telemetry record types (docs/robots.md) and their fields.
RECORDS: dict[str, dict[str, Spec]] = {
    "position": {"lat": _num(LAT, True), "lon": _num(LON, True), "heading": _num(HEADING),
                 "alt": _num("alt"), "relative_alt": _num("relative_alt"),
                 "vx": _num("velocity"), "vy": _num("velocity"), "vz": _num("velocity"),
                 "speed": _num("speed")},
    "battery": {"remaining": _num(PERCENT), "voltage": _num("voltage"),
                "current": _num("current")},
    "status": {"mode": TEXT, "armed": FLAG, "landed": FLAG, "at_base": FLAG, "teleop": FLAG,
               "failsafe": FLAG},
    "failsafe": {"event": TEXT, "action": TEXT, "mode": TEXT, "detail": TEXT},
    "hotspot": {"id": _int(Range(0, 2 ** 31 - 1), True), "lat": _num(LAT, True),
                "lon": _num(LON, True), "temperature": _num("temperature")},
    "text": {"severity": _int(Range(0, 7)), "text": TEXT},
    "mission": {"current": _int(Range(0, 65_535)), "total": _int(Range(0, 65_535)),
                "reached": _int(Range(0, 65_535))},
    "tank": {"level": _num("tank"), "capacity": _num("tank"), "pumping": FLAG},
}
#: The envelope fields every record has (besides its declared ones).
#: Fields checked wherever a record's type does not declare them (a project's own records).
COMMON: dict[str, Spec] = {"robot": TEXT, "type": TEXT, "ts": _num(Range(0.0, 1e11)),
                           "lat": _num(LAT), "lon": _num(LON), "alt": _num("alt"),
                           "battery": _num(PERCENT), "temperature": _num("temperature")}


def configured_robots(sections: Mapping[str, Any]) -> dict[str, RobotType]:
    """The robots of a project configuration (`[components.<id>.robots.<robot>]`, the
    RCL's robots table) and their types (by their `link` kind; ground without one)."""
    robots: dict[str, RobotType] = {}
    components = sections.get("components", {})
    if not isinstance(components, Mapping):
        return robots
    for table in components.values():
        table_robots = table.get("robots") if isinstance(table, Mapping) else None
        if not isinstance(table_robots, Mapping):
            continue
        for robot, options in table_robots.items():
            link = options.get("link", "") if isinstance(options, Mapping) else ""
            robots[str(robot)] = LINK_TYPES.get(str(link), RobotType.GROUND)
    return robots
