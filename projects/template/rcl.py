"""Robot Communication Layer (paper IV-E, Table I "Robot Communication Layer").

ADAPT:
- `connect_robot(robot, options)`: the link to each robot of
  `[components.rcl.robots.<id>]`. A real robot needs no code: `link = "mqtt"` or
  `"mavlink"` in its table and MRSS connects it (docs/robots.md, "Connecting robots";
  `mrss new NAME --with-sims` starts from that). This template drives an in-process
  `PointRobot` instead: `self.publish_data(robot, record)` sends telemetry to the data
  layer, `self.report_link(robot, up, reason)` tells MRSS it is reachable;
- `refine_action(action)`: the recipe of each agent action -> the skills that do it;
- optional: `check_action_status` (when is an action over; default: all skills
  succeeded), `action_cb` (if your actions are not `name(Robot, Goal, ...)`),
  `on_action_end` (keep data from a finished action), `resume_after_restart`.
Skills live in skills.py, imported below by path (no clash with other projects).

Resources a skill declares are arbitrated by the action's priority. The rule:
A resource is held by one action at a time (its skills share it). A request
pre-empts the holder if its priority is strictly higher; otherwise it waits.
Whenever the resource is free it goes to the highest-priority candidate among the
actions waiting for it and those pre-empted from it, the oldest request first among
equals.
"""

from __future__ import annotations

import threading
import time
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
    distance_m,
    import_project_module,
    step_towards,
)

skills = import_project_module(Path(__file__).resolve().parent, "skills.py")


class PointRobot:
    """A simulated robot in this process: drives in a straight line at `speed` m/s.

    ADAPT: replace it by a real link (docs/robots.md). It reports its position 5 times
    a second through `on_telemetry`, like a link does.
    """

    def __init__(self, robot: str, lat: float, lon: float, speed: float,
                 on_telemetry: Any) -> None:
        self.robot, self.lat, self.lon, self.speed = robot, lat, lon, speed
        self.home = (lat, lon)
        self.target: tuple[float, float] | None = None
        self.travelled_m = 0.0
        self._on_telemetry = on_telemetry
        self._lock = threading.Lock()
        self._stop = threading.Event()
        self._thread = threading.Thread(target=self._drive, name=f"sim-{robot}", daemon=True)
        self._thread.start()

    def goto(self, lat: float, lon: float) -> None:
        with self._lock:
            self.target, self.travelled_m = (lat, lon), 0.0

    def go_home(self) -> None:
        """Where a stand-down by area with mode home sends it (a link's `go_home`)."""
        self.goto(*self.home)

    def halt(self) -> None:
        with self._lock:
            self.target = None

    def arrived(self) -> bool:
        with self._lock:
            return self.target is not None and (self.lat, self.lon) == self.target

    def close(self) -> None:
        self._stop.set()
        self._thread.join(timeout=2)

    def _drive(self) -> None:
        period, last = 0.05, time.monotonic()
        while not self._stop.wait(period):
            now = time.monotonic()
            with self._lock:
                if self.target is not None:
                    lat, lon = step_towards(self.lat, self.lon, *self.target,
                                            self.speed * (now - last))
                    self.travelled_m += distance_m(self.lat, self.lon, lat, lon)
                    self.lat, self.lon = lat, lon
                record = {"type": "position", "lat": self.lat, "lon": self.lon,
                          "moving": self.target is not None
                          and (self.lat, self.lon) != self.target}
            last = now
            self._on_telemetry(record)


class ProjectRcl(RobotCommLayer):
    """ADAPT: the project's RCL (exactly one RobotCommLayer subclass in this file)."""

    #: ADAPT: the robot table keys this layer reads itself (`mrss check` type-checks them).
    robot_settings = (
        Option("home", list, [0.0, 0.0], "where the simulated robot starts", Check.POSITION),
        Option("speed", float, 5.0, "m/s, simulated", Check.POSITIVE),
    )

    def connect_robot(self, robot: str, options: Mapping[str, Any]) -> PointRobot:
        home = options.get("home", [0.0, 0.0])
        link = PointRobot(robot, float(home[0]), float(home[1]),
                          float(options.get("speed", 5.0)),
                          lambda record: self.publish_data(robot, record))
        self.report_link(robot, True)
        return link

    def refine_action(self, action: Action) -> list[Skill]:
        """ADAPT: one branch per action of agent.asl."""
        if action.name == "move" and len(action.args) == 4:   # move(Robot, Goal, Lat, Lon)
            lat, lon = action.args[2], action.args[3]
            if not all(isinstance(v, (int, float)) for v in (lat, lon)):
                raise ActionError("move: Lat and Lon must be numbers", uuid=action.uuid)
            return [skills.MoveTo(float(lat), float(lon))]
        return super().refine_action(action)
