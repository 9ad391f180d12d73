"""Whose robot data a component takes: only the component that owns the robot's link.

A robot's link lives in exactly one component, the one whose project.toml table lists
it (`[components.<id>.robots.<robot>]`: the RCL). Its data and state on the bus
(`robot.<robot>.data`, `robot.<robot>.state`) are taken from that component alone: a
message on a robot topic from any other sender (a tool, a forged socket, a robot the
project does not have) is refused and counted (`RejectionLog`: the dashboard's
refusals). On a bus with the run's incarnation key the owner must also prove its
incarnation (inc > 0: the bus's door has checked its credential, mrss/bus/incarnations.py);
replayed messages never get here. A project without any robots table is not checked.
"""

from __future__ import annotations

import logging
from collections.abc import Callable, Mapping
from pathlib import Path
from typing import Any

from mrss.config.loader import load_file
from mrss.config.projects import PROJECT_FILE
from mrss.edge.rejections import RejectionLog
from mrss.messages import Envelope, RobotData, RobotState

log = logging.getLogger("mrss.edge.robot_owners")


def robot_owners(sections: Mapping[str, Any]) -> dict[str, str]:
    """Robot id -> the id of the component whose table lists it (its link's owner)."""
    owners: dict[str, str] = {}
    components = sections.get("components", {})
    if not isinstance(components, Mapping):
        return owners
    for component, table in components.items():
        robots = table.get("robots") if isinstance(table, Mapping) else None
        if isinstance(robots, Mapping):
            for robot in robots:
                owners[str(robot)] = str(component)
    return owners


class RobotOwners:
    """Admits robot data and state only from the component that owns the robot's link."""

    def __init__(self, owners: Mapping[str, str], *, proven: bool = False,
                 refusals: RejectionLog | None = None) -> None:
        self.owners = dict(owners)
        self.proven = proven  # a keyed bus: the owner must carry a proven incarnation
        self.refusals = refusals or RejectionLog(log, "robot data")

    @classmethod
    def of_project(cls, project_dir: Path, *, proven: bool = False) -> RobotOwners:
        """The owners of the robots of the project in `project_dir`."""
        owners: dict[str, str] = {}
        if (project_dir / PROJECT_FILE).is_file():
            project = load_file(project_dir / PROJECT_FILE)
            owners = robot_owners({"components": {c.id: c.options
                                                  for c in project.components}})
        return cls(owners, proven=proven)

    def admits(self, env: Envelope) -> bool:
        """Whether `env` may be taken as robot data (any other kind of message may)."""
        body = env.body
        if not self.owners or not isinstance(body, (RobotData, RobotState)):
            return True
        robot = body.robot
        owner = self.owners.get(robot)
        if owner is not None and env.src == owner and (env.inc > 0 or not self.proven):
            return True
        if owner is None:
            reason = f"robot {robot[:40]!r} is not in the project"
        elif env.src != owner:
            reason = f"not from {owner}, the owner of its link"
        else:
            reason = f"{owner} without a proven incarnation"
        self.refusals.reject(env.src, reason, env.topic)
        return False

    def guard(self, handler: Callable[[Envelope], object]) -> Callable[[Envelope], None]:
        """`handler`, called only with what `admits` lets through."""
        def guarded(env: Envelope) -> None:
            if self.admits(env):
                handler(env)
        return guarded
