"""The project `mrss bench allocation` runs: a fleet whose tasks are addressed to a role.

Components: bus proxy, the simulated fleet (`mrss sim fleet`: half UAVs over MAVLink,
half UGVs over MQTT, every one with a camera), two scouts (`mrss sim uav` processes of
their own, the only robots with the capability `scout`, so the bench can take one away
and see its task go to the other), the RCL with one real link per robot, the reasoner.
The agent addresses every task to a role:

* `task(N, Lat, Lon)` -> `goto(any([camera], at(Lat, Lon)), N)`: the fleet's skill
  (`fleet_project.Assignment`) reads the clock first thing in `start()`;
* `hold(N, Lat, Lon)` -> `hold(any([scout], at(Lat, Lon)), N)`: a skill that reads the
  clock, keeps its progress and holds until it is interrupted.
"""

from __future__ import annotations

import time

from mrss.api import Action, Skill
from mrss.bench.fleet_project import FleetLayer
from mrss.links.geo import offset
from mrss.sim.uav import DEFAULT_HOME

PROJECT = "allocbench"
AGENT = """\
+task(N, Lat, Lon)[source(percept)] <-
    -task(N, Lat, Lon)[source(percept)];
    goto(any([camera], at(Lat, Lon)), N).
+hold(N, Lat, Lon)[source(percept)] <-
    -hold(N, Lat, Lon)[source(percept)];
    hold(any([scout], at(Lat, Lon)), N).
"""
RCL = """\
from mrss.bench.allocation_project import AllocationLayer


class Rcl(AllocationLayer):
    actions = {"goto": 2, "hold": 2}
"""
SCOUTS = ("scout1", "scout2")
LINK_TIMEOUT_S = 1.0  # the scouts' MAVLink heartbeat_timeout: lost after this long


def scout_home(k: int) -> tuple[float, float]:
    """Scout k (1, 2) stands 300 m, 600 m south of the fleet's grid."""
    return offset(DEFAULT_HOME[0], DEFAULT_HOME[1], -300.0 * k, 0.0)


class Hold(Skill):
    """Reads the clock, keeps it as progress, holds until interrupted (a long task)."""

    def __init__(self, seq: int) -> None:
        self.seq = seq

    def start(self) -> None:
        self.record_progress(seq=self.seq, t=time.monotonic_ns(), robot=self.robot)

    def run(self) -> bool:
        return not self.wait(3600.0)


class AllocationLayer(FleetLayer):
    """`goto(R, Seq)` as the fleet bench's; `hold(R, Seq)` holds R until interrupted."""

    def refine_action(self, action: Action) -> list[Skill]:
        if action.name == "hold":
            return [Hold(int(action.args[1]))]
        return super().refine_action(action)


def toml(uavs: int, ugvs: int, broker_url: str | None, rate: float) -> str:
    """project.toml of `uavs` + `ugvs` fleet robots and the two scouts."""
    robots = [f'uav{k} = {{ link = "mavlink", capabilities = ["uav", "camera"], '
              f'cruise_speed = 12.0 }}' for k in range(1, uavs + 1)]
    robots += [f'ugv{k} = {{ link = "mqtt", capabilities = ["ugv", "camera"], '
               f'cruise_speed = 3.0 }}' for k in range(1, ugvs + 1)]
    robots += [f'{s} = {{ link = "mavlink", capabilities = ["uav", "scout"], '
               f'heartbeat_timeout = {LINK_TIMEOUT_S} }}' for s in SCOUTS]
    scouts = "".join(f"""
[components.{s}]
kind = "sim_uav"
id = "{s}"
home = [{scout_home(k)[0]}, {scout_home(k)[1]}, {DEFAULT_HOME[2]}]
""" for k, s in enumerate(SCOUTS, start=1))
    return f"""\
[project]
name = "{PROJECT}"

[supervisor]
heartbeat_interval = 0.5

{f'[broker]{chr(10)}url = "{broker_url}"' if broker_url else ""}

[components.bus]
kind = "bus"
{"" if broker_url else '[components.broker]' + chr(10) + 'kind = "broker"'}

[components.fleet]
kind = "sim_fleet"
start_timeout = 120.0
uav = {uavs}
ugv = {ugvs}
rate = {rate}
speedup = 1.0
{scouts}
[components.rcl]
kind = "rcl"
start_timeout = 120.0
robots = {{ {", ".join(robots)} }}

[components.reasoner]
kind = "reasoner"
"""
