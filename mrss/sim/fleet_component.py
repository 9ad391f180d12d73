"""`mrss sim fleet` as a supervised component: many simulated robots in one process.

    [components.fleet]
    kind = "sim_fleet"
    uav = 50                          # uav1..uav50, MAVLink over loopback UDP (addresses in
                                      # <run_dir>/uav<k>.mavlink, found by link = "mavlink")
    ugv = 50                          # ugv1..ugv50 on the project's broker (link = "mqtt")
    rate = 5.0                        # position telemetry per second per robot
    speedup = 1.0                     # $MRSS_SIM_SPEEDUP overrides
    home = [-35.363262, 149.165237, 584.0]   # robots stand on a 50 m grid from here
    # broker_url = "mqtt://..."       # default: the project's broker

It starts before the RCL, as `sim_uav` / `sim_ugv` do (docs/robots.md).
"""

from __future__ import annotations

from typing import ClassVar

from mrss.errors import ConfigError
from mrss.options import Check, Option
from mrss.runtime.component import Component, ComponentContext
from mrss.sim.component import number, position, project_broker_url, speedup_of
from mrss.sim.fleet import FleetSpec, SimFleet
from mrss.sim.uav import DEFAULT_HOME


class SimFleetComponent(Component):
    """A fleet of simulated UAVs and UGVs served by one event loop."""

    OPTIONS: ClassVar[tuple[Option, ...]] = (
        Option("uav", int, 0, "simulated UAVs uav1..uavN", Check.NON_NEGATIVE),
        Option("ugv", int, 0, "simulated UGVs ugv1..ugvM", Check.NON_NEGATIVE),
        Option("rate", float, 5.0, "position telemetry per second per robot", Check.POSITIVE),
        Option("speedup", float, 1.0, "simulated time per real second", Check.POSITIVE),
        Option("home", list, list(DEFAULT_HOME), "[lat, lon, alt] the grid starts at",
               Check.POSITION),
        Option("broker_url", str, None, "MQTT broker (default: the project's)", Check.URL),
    )

    def __init__(self) -> None:
        self.fleet: SimFleet | None = None

    def start(self, ctx: ComponentContext) -> None:
        opts = ctx.options
        ugvs = int(number(opts, "ugv", 0))
        home = position(opts, "home", DEFAULT_HOME, 3)
        spec = FleetSpec(uavs=int(number(opts, "uav", 0)), ugvs=ugvs,
                         rate=number(opts, "rate", 5.0), speedup=speedup_of(opts),
                         home=(home[0], home[1], home[2]),
                         broker_url=project_broker_url(ctx) if ugvs else "",
                         run_dir=ctx.run_dir)
        try:
            fleet = SimFleet(spec)
        except ValueError as exc:
            raise ConfigError(str(exc), key="uav") from None
        self.fleet = fleet.start()
        ctx.log.info("simulated fleet: %d UAV(s), %d UGV(s), telemetry %g/s each",
                     spec.uavs, spec.ugvs, spec.rate)

    def healthy(self) -> bool:
        return self.fleet is not None and self.fleet.alive()

    def stop(self) -> None:
        if self.fleet is not None:
            self.fleet.stop()
