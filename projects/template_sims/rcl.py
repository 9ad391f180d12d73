"""Robot Communication Layer: the recipes of the two simulated robots.

The links need no code: each robot's table in project.toml names its `link`
(`"mavlink"` for uav1, `"mqtt"` for ugv1) and the default `connect_robot` builds it,
with the simulator's address and the project's broker found by MRSS, and forwards its
telemetry to the data layer and its state (a lost link makes the robot unavailable).

ADAPT: `refine_action(action)`, one recipe per action of agent.asl:

    fly(uav1, G, Lat, Lon)      FlyTo: take off if landed, fly there, hover
    drive(ugv1, G, Lat, Lon)    DriveTo: drive there

and `robot_settings`, the robot table keys this layer reads itself (`mrss check`
type-checks them; the link never sees them).
"""

from __future__ import annotations

from collections.abc import Mapping
from pathlib import Path
from typing import Any

from mrss.api import (
    Action,
    ActionError,
    Check,
    Option,
    RobotCommLayer,
    Skill,
    import_project_module,
)

skills = import_project_module(Path(__file__).resolve().parent, "skills.py")


def _point(action: Action) -> tuple[float, float]:
    lat, lon = action.args[2], action.args[3]
    if isinstance(lat, bool) or isinstance(lon, bool) \
            or not isinstance(lat, (int, float)) or not isinstance(lon, (int, float)):
        raise ActionError(f"{action.name}: Lat and Lon must be numbers", uuid=action.uuid)
    return float(lat), float(lon)


class ProjectRcl(RobotCommLayer):
    """ADAPT: the project's RCL (exactly one RobotCommLayer subclass in this file)."""

    interrupt_timeout = 10.0    # a MAVLink mode change may take a few retries
    #: ADAPT: the robot table keys this layer reads itself (not link options), typed.
    robot_settings = (Option("altitude", float, 20.0, "UAV cruise altitude, m above home",
                             Check.POSITIVE),)

    def __init__(self) -> None:
        self.altitude: dict[str, float] = {}

    def connect_robot(self, robot: str, options: Mapping[str, Any]) -> Any:
        """Keep this layer's setting; MRSS builds the link from the rest of the table."""
        self.altitude[robot] = float(options.get("altitude", 20.0))
        return super().connect_robot(robot, options)

    def refine_action(self, action: Action) -> list[Skill]:
        if action.name == "fly" and len(action.args) == 4:      # fly(R, G, Lat, Lon)
            return [skills.FlyTo(*_point(action), self.altitude.get(action.robot, 20.0))]
        if action.name == "drive" and len(action.args) == 4:    # drive(R, G, Lat, Lon)
            return [skills.DriveTo(*_point(action))]
        return super().refine_action(action)
