"""What a robot declares for allocation, in its project.toml table, read once.

`[components.rcl.robots.uav1]` may say `capabilities = ["uav", "camera"]` (what tasks
addressed to a role may ask of it), `cruise_speed` (m/s, for time estimates),
`battery_per_km` (% of battery a km costs), `battery_reserve` (% it keeps to get home),
`battery_critical` (% below which it is lost for the tasks addressed to a role it holds:
they go to others) and `base` ([lat, lon]: where home is; default: where it was first
seen). They are the
RCL's keys, not the link's (`ALLOCATION_KEYS`): set aside before `connect_robot`.
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass
from typing import Any

from mrss.options import Check, Option, OptionValues

ROBOT_ALLOCATION_OPTIONS: tuple[Option, ...] = (
    Option("capabilities", list, [], "what the robot can do: the names a task addressed "
           "to a role asks for (any([uav, camera]))"),
    Option("cruise_speed", float, 5.0, "m/s the robot travels at, for time estimates",
           Check.POSITIVE),
    Option("battery_per_km", float, 1.0, "% of battery a km of travel costs",
           Check.NON_NEGATIVE),
    Option("battery_reserve", float, 20.0, "% of battery kept to get home",
           Check.NON_NEGATIVE),
    Option("battery_critical", float, 10.0, "% of battery below which the robot is lost "
           "for the tasks addressed to a role it holds: they go to other robots (0: never)",
           Check.NON_NEGATIVE),
    Option("base", list, None, "[lat, lon] of home (default: where the robot was first "
           "seen)", Check.POSITION),
)
ALLOCATION_KEYS = tuple(o.name for o in ROBOT_ALLOCATION_OPTIONS)


@dataclass(frozen=True)
class RobotProfile:
    """A robot's declared capabilities and travel figures."""

    robot: str
    capabilities: frozenset[str] = frozenset()
    cruise_speed: float = 5.0
    battery_per_km: float = 1.0
    battery_reserve: float = 20.0
    base: tuple[float, float] | None = None
    battery_critical: float = 10.0

    @classmethod
    def read(cls, robot: str, table: Mapping[str, Any], section: str = "") -> RobotProfile:
        """From the robot's table (ConfigError naming the key if a value is wrong)."""
        values = OptionValues(ROBOT_ALLOCATION_OPTIONS, table, section=section)
        caps = values["capabilities"]
        base = values["base"]
        return cls(robot, frozenset(str(c) for c in caps), values.number("cruise_speed"),
                   values.number("battery_per_km"), values.number("battery_reserve"),
                   (float(base[0]), float(base[1])) if base else None,
                   values.number("battery_critical"))

    def can(self, capabilities: frozenset[str]) -> bool:
        return capabilities <= self.capabilities


def split_table(table: Mapping[str, Any]) -> tuple[dict[str, Any], dict[str, Any]]:
    """(the allocation keys, the rest for connect_robot) of a robot's table."""
    mine = {k: v for k, v in table.items() if k in ALLOCATION_KEYS}
    return mine, {k: v for k, v in table.items() if k not in ALLOCATION_KEYS}
