"""Robot Communication Layer of the wildfire project (paper IV-E, V): links and recipes.

Robots come from `[components.rcl.robots.<id>]` of project.toml:

    [components.rcl.robots.uav1]
    link = "mavlink"            # the simulator with id = "uav1"; or url = "udpin:..."
    altitude = 30.0             # recipe settings (see ROBOT_SETTINGS), the rest goes to the link
    [components.rcl.robots.ugv1]
    link = "mqtt"               # broker_url defaults to the project's broker

MRSS builds each link (RobotCommLayer.connect_robot, docs/robots.md "Connecting robots"):
every telemetry record of a link goes to the data layer (`robot.<id>.data`), and a link
going down makes its robot unavailable (the reasoner perceives `robot_unavailable(R)`).

Recipes (action -> skills), actions being `name(Robot, Goal, ...)`:

    cover(uav1, Area)                         CoverArea over area_polygon(Area) (data layer)
                                              (agent.asl asks it of any([uav, camera]))
    recharge(uav1, G)                         ReturnHome, then wait for the battery swap
    return_home(uav1, G), land(uav1, G)       ReturnHome, Land
    supply_water(ugv1, H, Lat, Lon, Litres)   SupplyWater (drive, then pump)
                                              (asked of any([ugv, water], at(Lat, Lon)))
    goto(ugv1, G, Lat, Lon), pump(ugv1, G, L) GotoPoint, Pump
    refill(ugv1, G), return_to_base(ugv1, G)  ReturnToBase (waiting for a full tank), ReturnToBase
    teleop_mode(ugv1, on|off)                 TeleopSwitch

A cover action that ends unfinished (cancelled, failed) leaves its last waypoint
behind: the next cover action of the same goal starts from there, on whichever UAV the
RCL awards it to (the paper's "data from a previous execution"). A cover asked again
while the area's earlier cover is still stopping (a priority change: the agent cancels
and asks anew, and another UAV may be given it at once) waits for that one to end
before it reads where to start (`CoveredAreas`), at most `SETTLE_S`. A cover or supply
addressed to a role (`cover(any([uav, camera]), Area)`, docs/rcl.md "Allocation") is
refined once the RCL has awarded it: `action.robot` is the winner; one handed on from a
lost robot keeps its progress (`Skill.progress`), so the next UAV starts at the
waypoint the lost one had reached.
"""

from __future__ import annotations

import threading
from collections.abc import Mapping
from pathlib import Path
from typing import Any

from mrss.api import (
    Action,
    ActionError,
    ActionState,
    RobotCommLayer,
    Skill,
    import_project_module,
)

# Sibling modules are imported by path under private names, so two projects' skills.py
# never collide in one process (and no installed package shadows them).
HERE = Path(__file__).resolve().parent
skills = import_project_module(HERE, "skills.py")
sweep = import_project_module(HERE, "sweep.py")

# Robot options read by the recipes (not link options), with their defaults.
ROBOT_SETTINGS: dict[str, float] = {"altitude": 30.0, "lane_spacing": 40.0,
                                    "charge_to": 95.0, "litres_per_second": 5.0}


def _number(value: Any, what: str, uuid: str) -> float:
    if isinstance(value, bool) or not isinstance(value, (int, float)):
        raise ActionError(f"{what} must be a number, not {value!r}", uuid=uuid)
    return float(value)


#: How long a cover waits for the area's earlier cover to end before it starts anyway
#: (from what is known then): the RCL's interrupt_timeout, and a little more.
SETTLE_S = 12.0


class CoveredAreas:
    """Per area (the goal): how many waypoints its unfinished covers reached, and which
    of its covers are open, so a new one starts where the last one stopped."""

    def __init__(self) -> None:
        self._reached: dict[str, int] = {}
        self._open: dict[str, set[str]] = {}  # goal -> uuids of its open covers
        self._lock = threading.Lock()

    def opened(self, goal: str, uuid: str) -> None:
        with self._lock:
            self._open.setdefault(goal, set()).add(uuid)

    def ended(self, action: Action) -> None:
        """A cover ended: done, the area is forgotten; unfinished, its reach is kept."""
        with self._lock:
            self._open.get(action.goal, set()).discard(action.uuid)
            if action.state is ActionState.SUCCEEDED:
                self._reached.pop(action.goal, None)
                return
            reached = action.progress.get("waypoint", 0)
            if isinstance(reached, int) and reached > self._reached.get(action.goal, 0):
                self._reached[action.goal] = reached

    def settled(self, goal: str, uuid: str) -> bool:
        """No cover of `goal` but `uuid` is open: where the area stands is final."""
        with self._lock:
            return not self._open.get(goal, set()) - {uuid}

    def start(self, goal: str) -> int:
        with self._lock:
            return self._reached.get(goal, 0)


class WildfireRcl(RobotCommLayer):
    """Links to the UAVs (MAVLink) and the UGVs (MQTT), and the recipes of the scenario."""

    interrupt_timeout = 10.0  # a MAVLink mode change may take a few retries
    robot_settings = tuple(ROBOT_SETTINGS)  # not link options (set aside, and `mrss check`)

    def __init__(self) -> None:
        self.settings: dict[str, dict[str, float]] = {}
        self.areas = CoveredAreas()  # how far each area's covers got, by any UAV

    # -- links ----------------------------------------------------------------------------
    def connect_robot(self, robot: str, options: Mapping[str, Any]) -> Any:
        """Keep the recipe settings; MRSS builds the link (simulator addresses, broker)."""
        self.settings[robot] = {k: float(options.get(k, default))
                                for k, default in ROBOT_SETTINGS.items()}
        return super().connect_robot(robot, options)

    # -- recipes --------------------------------------------------------------------------
    def refine_action(self, action: Action) -> list[Skill]:
        s = self.settings.get(action.robot, dict(ROBOT_SETTINGS))
        args, name, uuid = action.args, action.name, action.uuid
        if name == "cover":
            polygon = self.data_call("area_polygon", action.goal)
            waypoints = sweep.lawnmower(polygon, s["lane_spacing"])
            goal, areas = action.goal, self.areas
            areas.opened(goal, uuid)
            return [skills.CoverArea(waypoints, s["altitude"],
                                     start_at=lambda: areas.start(goal),
                                     settled=lambda: areas.settled(goal, uuid),
                                     settle_s=SETTLE_S)]
        if name == "recharge":
            return [skills.ReturnHome(charge_to=s["charge_to"])]
        if name == "return_home":
            return [skills.ReturnHome()]
        if name == "land":
            return [skills.Land()]
        if name == "supply_water" and len(args) == 5:
            lat, lon, litres = (_number(a, w, uuid) for a, w in
                                zip(args[2:], ("Lat", "Lon", "Litres"), strict=True))
            return [skills.SupplyWater(lat, lon, litres)]
        if name == "goto" and len(args) == 4:
            return [skills.GotoPoint(_number(args[2], "Lat", uuid),
                                     _number(args[3], "Lon", uuid))]
        if name == "pump" and len(args) == 3:
            return [skills.Pump(_number(args[2], "Litres", uuid))]
        if name == "refill":
            return [skills.ReturnToBase(refill=True)]
        if name == "return_to_base":
            return [skills.ReturnToBase()]
        if name == "teleop_mode" and action.goal in ("on", "off"):
            return [skills.TeleopSwitch(action.goal == "on")]
        return super().refine_action(action)

    def on_action_end(self, action: Action) -> None:
        """Remember how far an unfinished cover got, for the next try of that area."""
        if action.name == "cover":
            self.areas.ended(action)
