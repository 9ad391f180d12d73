"""The project `mrss bench fleet` runs: its files, its RCL layer, its data layer.

Components: bus proxy, world model (SQLite), data layer, the simulated fleet (`mrss sim
fleet` as a component), the RCL with one real link per robot (MAVLink over UDP per UAV,
MQTT per UGV, on a private Mosquitto) and the reasoner. Robots declare their kind as
their capability (`uav` or `ugv`), and the agent addresses each goal to that role, not
to a robot: an `assign(Kind, Seq)` percept becomes the action `goto(any([Kind]), Seq)`,
which the RCL's allocator awards to the best free robot of that kind (docs/rcl.md,
"Allocation"); the skill on the winner reads the clock
first thing in `start()` (kept as progress) and then commands the robot over its link
(a UGV drives 20 m, a UAV is switched to GUIDED). The data layer writes every telemetry
record to the world model (the default `on_telemetry`) and tells the agent when a robot
starts or stops moving (`moving(R)`), which the agent tracks as a belief.
"""

from __future__ import annotations

import enum
import time
from collections.abc import Mapping
from typing import Any

from mrss.api import Action, DataLayer, RobotCommLayer, Skill
from mrss.links.geo import offset

PROJECT = "fleetbench"
AGENT = """\
+assign(K, N)[source(percept)] <- -assign(K, N)[source(percept)]; goto(any([K]), N).
+moving(R)[source(percept)] <- +busy(R).
-moving(R)[source(percept)] <- -busy(R).
"""
RCL = """\
from mrss.bench.fleet_project import FleetLayer


class Rcl(FleetLayer):
    actions = {"goto": 2}  # its recipe is FleetLayer's
"""
DATALAYER = """\
from mrss.bench.fleet_project import FleetDataLayer


class Data(FleetDataLayer):
    pass
"""
MOVING_MPS = 0.5


# The action path (bus, rcl, reasoner) and the telemetry path (data layer, world model)
# as docs/config.md, "CPU scheduling", advises; the simulated fleet stays ordinary.
FAVOURED = "realtime = 10"
TELEMETRY = "nice = -10"


class Scheduling(enum.Enum):
    """How the bench project's components are scheduled."""

    DEFAULTS = "shipped defaults"  # no scheduling keys: what a project runs with
    TUNED = "tuned (opt-in)"  # FAVOURED and TELEMETRY: realtime no shipped project sets


def toml(uavs: int, ugvs: int, broker_url: str | None, rate: float,
         scheduling: Scheduling = Scheduling.TUNED) -> str:
    """project.toml of a fleet of `uavs` + `ugvs` robots on the broker at `broker_url`
    (None: the embedded broker, a component of the project), scheduled as `scheduling`."""
    tuned = scheduling is Scheduling.TUNED
    favoured, telemetry = (FAVOURED, TELEMETRY) if tuned else ("", "")
    robots = [f"uav{k} = {{ link = \"mavlink\", capabilities = [\"uav\"] }}"
              for k in range(1, uavs + 1)]
    robots += [f"ugv{k} = {{ link = \"mqtt\", capabilities = [\"ugv\"] }}"
               for k in range(1, ugvs + 1)]
    return f"""\
[project]
name = "{PROJECT}"

[supervisor]
heartbeat_interval = 0.5

{f'[broker]{chr(10)}url = "{broker_url}"' if broker_url else ""}

[components.bus]
kind = "bus"
{favoured}
{"" if broker_url else '[components.broker]' + chr(10) + 'kind = "broker"'}

[components.worldmodel]
kind = "worldmodel"
{telemetry}

[components.datalayer]
kind = "datalayer"
{telemetry}

[components.fleet]
kind = "sim_fleet"
start_timeout = 120.0
uav = {uavs}
ugv = {ugvs}
rate = {rate}
speedup = 1.0

[components.rcl]
kind = "rcl"
start_timeout = 120.0
{favoured}
robots = {{ {", ".join(robots)} }}

[components.reasoner]
kind = "reasoner"
{favoured}
"""


class Assignment(Skill):
    """Reads the clock first in `start`, keeps it as progress, then commands the robot."""

    def __init__(self, seq: int) -> None:
        self.seq = seq

    def start(self) -> None:
        self.record_progress(seq=self.seq, t=time.monotonic_ns())

    def run(self) -> bool:
        link: Any = self.link
        if link is None:
            return False
        if self.robot.startswith("ugv"):
            position = link.latest("position") or {}
            if "lat" in position:
                lat, lon = offset(position["lat"], position["lon"], 20.0 * (self.seq % 2 or -1),
                                  0.0)
                link.goto(lat, lon, wait=False)
        else:
            link.set_mode("GUIDED")
        return True


class FleetLayer(RobotCommLayer):
    """`goto(Role, Seq)` -> one Assignment skill on the robot that won the task (real
    links by default)."""

    def refine_action(self, action: Action) -> list[Skill]:
        if action.name == "goto":
            return [Assignment(int(action.args[1]))]
        return super().refine_action(action)


class FleetDataLayer(DataLayer):
    """Every record to the world model; `moving(R)` while a robot's speed is above 0.5 m/s."""

    def start(self) -> None:
        self._moving: dict[str, bool] = {}

    def on_telemetry(self, robot: str, data: Mapping[str, Any]) -> None:
        super().on_telemetry(robot, data)
        if data.get("type") != "position":
            return
        speed = data.get("speed")
        if speed is None:
            speed = (float(data.get("vx") or 0.0) ** 2 + float(data.get("vy") or 0.0) ** 2) ** 0.5
        moving = float(speed) > MOVING_MPS
        if moving != self._moving.get(robot, False):
            self._moving[robot] = moving
            percept = self.context.percept
            if percept is not None:
                percept("moving", robot, op="add" if moving else "remove")
