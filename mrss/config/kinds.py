"""The kinds of component MRSS ships, by the name project.toml gives them: one registry.

A `[components.<id>]` table names what it runs by kind (`kind = "rcl"`); a project's own
component names its class instead (`module = "myproject.beacon:Beacon"`, its folder on
the import path). Each kind resolves here, and only here, to the class the root starts
and to its child kind (a supervisor of actors, or a worker). The table is data: the
names are the contract, the class paths behind them may move between releases.

Earlier releases named the shipped classes by their module paths. Those paths (in
`FORMER_TARGETS`) still start, as the kind they meant, with a warning that shows the new
spelling; `mrss check` names each with its file and line.
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass
from enum import StrEnum

from mrss.supervision.spec import ChildKind


class ComponentKind(StrEnum):
    """The components MRSS ships, as `kind = "..."` names them."""

    BUS = "bus"                  # the ZeroMQ proxy every other component talks through
    BROKER = "broker"            # the embedded MQTT broker
    WORLDMODEL = "worldmodel"    # the World Model
    DATALAYER = "datalayer"      # the Symbol and Data Layer (the project's datalayer.py)
    EVENTS = "events"            # the External Events Manager (the project's events.py)
    RCL = "rcl"                  # the Robot Communication Layer (rcl.py, skills.py)
    REASONER = "reasoner"        # the Reasoner (agent.asl)
    SIM_UAV = "sim_uav"          # a simulated UAV speaking MAVLink
    SIM_UGV = "sim_ugv"          # a simulated UGV speaking JSON over MQTT
    SIM_FLEET = "sim_fleet"      # a fleet of simulated robots in one process
    FOXGLOVE = "foxglove"        # the live bus as a Foxglove WebSocket server (optional)


@dataclass(frozen=True)
class Kind:
    """What a kind starts: the component class (`module:Class`) and its child kind."""

    target: str
    child: ChildKind = ChildKind.WORKER


KINDS: Mapping[ComponentKind, Kind] = {
    ComponentKind.BUS: Kind("mrss.actors.proxy.service:ProxyComponent"),
    ComponentKind.BROKER: Kind("mrss.actors.broker.service:EmbeddedBroker"),
    ComponentKind.WORLDMODEL: Kind("mrss.actors.worldmodel.service:WorldModelComponent"),
    ComponentKind.DATALAYER: Kind("mrss.actors.datalayer.service:DataLayerComponent"),
    ComponentKind.EVENTS: Kind("mrss.actors.events.service:ExternalEventsManager"),
    ComponentKind.RCL: Kind("mrss.actors.rcl.service:RclService", ChildKind.SUPERVISOR),
    ComponentKind.REASONER: Kind("mrss.actors.reasoner.service:ReasonerComponent"),
    ComponentKind.SIM_UAV: Kind("mrss.sim.component:SimUavComponent"),
    ComponentKind.SIM_UGV: Kind("mrss.sim.component:SimUgvComponent"),
    ComponentKind.SIM_FLEET: Kind("mrss.sim.fleet_component:SimFleetComponent"),
    ComponentKind.FOXGLOVE: Kind("mrss.actors.foxglove.service:FoxgloveComponent"),
}

#: The module paths earlier releases' project.toml files named, and the kind each meant.
FORMER_TARGETS: Mapping[str, ComponentKind] = {
    "mrss.bus.component:ProxyComponent": ComponentKind.BUS,
    "mrss.broker:EmbeddedBroker": ComponentKind.BROKER,
    "mrss.actors.worldmodel:WorldModelComponent": ComponentKind.WORLDMODEL,
    "mrss.actors.datalayer:DataLayerComponent": ComponentKind.DATALAYER,
    "mrss.actors.events:ExternalEventsManager": ComponentKind.EVENTS,
    "mrss.actors.rcl_service:RclService": ComponentKind.RCL,
    "mrss.actors.reasoner:ReasonerComponent": ComponentKind.REASONER,
}  # the simulators' paths are unchanged: KINDS has them


def kind_of_target(target: str) -> ComponentKind | None:
    """The kind a `module:Class` path means: today's path or a former one; None for a
    project's own class."""
    for kind, entry in KINDS.items():
        if entry.target == target:
            return kind
    return FORMER_TARGETS.get(target)
