"""A task addressed to a role: what it needs (capabilities) and where it is (optional).

The agent writes `cover(any([uav, camera]), G, Area)` or `any([camera], at(Lat, Lon))`;
the reasoner sends the role as `ActionRequest.role` = {"capabilities": [...], "near":
[lat, lon]} with no robot. `Task.of` reads and checks it (ActionError: the request is
rejected with that reason).
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any

from mrss.errors import ActionError
from mrss.messages import ActionRequest
from mrss.messages.roles import CAPABILITIES, NEAR


@dataclass(frozen=True)
class Task:
    """One open task: its action request's uuid, name and priority, and what it needs."""

    uuid: str
    name: str
    capabilities: frozenset[str]
    near: tuple[float, float] | None = None
    priority: int = 0

    @classmethod
    def of(cls, request: ActionRequest) -> Task:
        """The task of a role-addressed request; ActionError if its role is malformed."""
        return cls(request.uuid, request.name, capabilities_of(request.role),
                   near_of(request.role), request.priority)

    def describe(self) -> str:
        """"any robot with uav, camera near 48.2000, 16.3000" (for reasons and logs)."""
        text = "any robot with " + ", ".join(sorted(self.capabilities))
        return text + (f" near {self.near[0]:.4f}, {self.near[1]:.4f}" if self.near else "")


def capabilities_of(role: dict[str, Any]) -> frozenset[str]:
    caps = role.get(CAPABILITIES)
    if not isinstance(caps, list) or not caps or not all(isinstance(c, str) and c
                                                          for c in caps):
        raise ActionError(f"a role needs a non-empty list of capability names, not {caps!r}")
    unknown = sorted(set(role) - {CAPABILITIES, NEAR})
    if unknown:
        raise ActionError(f"a role has capabilities and near, not {', '.join(unknown)}")
    return frozenset(caps)


def near_of(role: dict[str, Any]) -> tuple[float, float] | None:
    near = role.get(NEAR)
    if near is None:
        return None
    if not (isinstance(near, list) and len(near) == 2
            and all(isinstance(v, int | float) and not isinstance(v, bool)
                    and math.isfinite(v) for v in near)
            and -90 <= near[0] <= 90 and -180 <= near[1] <= 180):
        raise ActionError(f"a role's place must be [lat, lon] in degrees, not {near!r}")
    return float(near[0]), float(near[1])
