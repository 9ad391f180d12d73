"""Robot Communication Layer of the AMADEE-24 rover: its recipes.

The link needs no code: the robot's table in project.toml says `link = "mqtt"` and MRSS
connects it to the project's broker, where the rover (or its simulator) listens.

Recipes (the reasoner sends an action only once the data layer found it legal):

    drive(rover1, G, Lat, Lon)      DriveTo
    return_home(rover1, G)          ReturnHome (to the habitat, the rover's base)
    image | spectrum | radar | sample (rover1, G)   Observe, `dwell_s` seconds standing
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


SCIENCE = ("image", "spectrum", "radar", "sample")


def _point(action: Action) -> tuple[float, float]:
    lat, lon = action.args[2], action.args[3]
    if isinstance(lat, bool) or isinstance(lon, bool) \
            or not isinstance(lat, (int, float)) or not isinstance(lon, (int, float)):
        raise ActionError(f"{action.name}: Lat and Lon must be numbers", uuid=action.uuid)
    return float(lat), float(lon)


class AmadeeRcl(RobotCommLayer):
    """The rover's recipes."""

    #: The actions of these recipes, by arity (the science ones are matched by name).
    actions = {"drive": 4, "return_home": 2, **{name: 2 for name in SCIENCE}}
    #: The robot table keys this layer reads itself (not link options), typed.
    robot_settings = (Option("dwell_s", float, 2.0, "seconds the rover stands for a "
                             "science task", Check.NON_NEGATIVE),)

    def __init__(self) -> None:
        self.dwell: dict[str, float] = {}

    def connect_robot(self, robot: str, options: Mapping[str, Any]) -> Any:
        self.dwell[robot] = float(options.get("dwell_s", 2.0))
        return super().connect_robot(robot, options)

    def refine_action(self, action: Action) -> list[Skill]:
        if action.name == "drive" and len(action.args) == 4:    # drive(R, G, Lat, Lon)
            return [skills.DriveTo(*_point(action))]
        if action.name == "return_home":
            return [skills.ReturnHome()]
        if action.name in SCIENCE:
            return [skills.Observe(action.name, self.dwell.get(action.robot, 2.0))]
        return super().refine_action(action)
