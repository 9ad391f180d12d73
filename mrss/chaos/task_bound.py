"""How soon a task addressed to a role must be awarded: the award-bounded invariant's bound,
derived from the project's configuration (the campaign records it; the checker reads it).

A task waits while no capable robot can take it. Once one can (capable, available, its
link up, not in teleop, holding no action, and not lost), the RCL awards it within

    link_loss + allocation + margin        (plus, when they fall in the wait, each
                                            stall of the RCL or the bus and each
                                            restart of the RCL: `extension`)

- `link_loss`: the longest link timeout of the project's robots (a MAVLink robot's
  `heartbeat_timeout`, an MQTT robot's `telemetry_timeout`, an HTTP robot's `timeout`;
  each link's own default when its table sets none). A robot lost mid-task does not say
  so: the RCL learns it when its link has been silent that long, and only then gives
  its task back. The wait of such a task is counted from the loss itself (the fault),
  so its bound must cover the silence.
- `allocation`: one round of the allocator after that: its retry period (a round runs
  at least that often). A round is decided in one pass over the fleet's states under
  the RCL's lock, asking no robot actor to confirm its bid, so it adds no wait per robot.
- `margin`: the statuses' and allocations' travel on the bus and the scheduling of a
  loaded machine (`MARGIN`).
- `restart`: an RCL killed during the wait comes back within the root supervisor's
  backoff cap plus the RCL's `start_timeout`; it then makes its book whole and bids
  the task out again. Added once per death of an RCL incarnation, kill of the bus proxy
  or of the fork server (everything restarts), in the wait or up to `restart` s before
  it (a request sent while the RCL was down waits for it).
- a stall: a `hang`, `blackout` or `disk_full` of a component in `stalls` (the RCLs and
  the bus proxy) holds every decision up for its duration; added per such fault.
"""

from __future__ import annotations

import inspect
from dataclasses import asdict, dataclass
from typing import Any

from mrss.actors.rcl.allocation.allocator import Allocator
from mrss.config.kinds import ComponentKind
from mrss.config.project import ProjectConfig
from mrss.links.http import HttpLink
from mrss.links.mavlink import MavlinkLink
from mrss.links.mqtt import MqttLink

#: Seconds for the bus's travel and a loaded 2-core machine's scheduling.
MARGIN = 3.0
#: Per link kind: the option that says how long its robot may be silent, and its class.
LINK_TIMEOUTS: dict[str, tuple[str, type]] = {
    "mavlink": ("heartbeat_timeout", MavlinkLink),
    "mqtt": ("telemetry_timeout", MqttLink),
    "http": ("timeout", HttpLink),
}


@dataclass(frozen=True)
class AwardBound:
    """The parts of the bound, in seconds (the module says why each)."""

    link_loss: float
    allocation: float
    restart: float
    margin: float = MARGIN
    stalls: tuple[str, ...] = ()  # the components whose stall holds an award up

    @property
    def base(self) -> float:
        return self.link_loss + self.allocation + self.margin

    def record(self) -> dict[str, Any]:
        """As the campaign record keeps it."""
        return {**asdict(self), "stalls": list(self.stalls), "base": self.base}

    @classmethod
    def of_record(cls, record: Any) -> AwardBound | None:
        """From a campaign record (None: the history has none, or not a readable one)."""
        if not isinstance(record, dict):
            return None
        try:
            return cls(float(record["link_loss"]), float(record["allocation"]),
                       float(record["restart"]), float(record.get("margin", MARGIN)),
                       tuple(str(s) for s in record.get("stalls") or ()))
        except (KeyError, TypeError, ValueError):
            return None


def robot_capabilities(config: ProjectConfig) -> dict[str, list[str]]:
    """robot -> the capabilities its RCL table declares (what `any([...])` may ask of it)."""
    out: dict[str, list[str]] = {}
    for rcl in config.of_kind(ComponentKind.RCL):
        robots = rcl.options.get("robots") or {}
        for robot, table in robots.items() if isinstance(robots, dict) else ():
            caps = table.get("capabilities") if isinstance(table, dict) else None
            out[str(robot)] = sorted(str(c) for c in caps) if isinstance(caps, list) else []
    return out


def award_bound(config: ProjectConfig) -> AwardBound:
    """The bound for this project (the module's rules)."""
    link_loss, restart = 0.0, 0.0
    cap = config.supervisor.spec.backoff.cap
    for rcl in config.of_kind(ComponentKind.RCL):
        restart = max(restart, cap + rcl.start_timeout)
        tables = rcl.options.get("robots") or {}
        for table in tables.values() if isinstance(tables, dict) else ():
            link_loss = max(link_loss, link_timeout(table if isinstance(table, dict) else {}))
    stalls = tuple(c.id for c in config.components
                   if c.kind in (ComponentKind.RCL, ComponentKind.BUS))
    return AwardBound(link_loss, _retry_every(), restart, stalls=stalls)


def link_timeout(table: dict[str, Any]) -> float:
    """How long the robot of this table may be silent before its link is down (its
    link's own default when the table says nothing; 0 for a robot without a link)."""
    kind = table.get("link")
    if kind not in LINK_TIMEOUTS:
        return 0.0
    key, link_class = LINK_TIMEOUTS[str(kind)]
    value = table.get(key)
    if isinstance(value, int | float) and not isinstance(value, bool):
        return float(value)
    return float(inspect.signature(link_class).parameters[key].default)


def _retry_every() -> float:
    """The allocator's own retry period (its declared default: it is no option)."""
    parameter = inspect.signature(Allocator).parameters.get("retry_every")
    default = parameter.default if parameter is not None else None
    return float(default) if isinstance(default, int | float) else 1.0
