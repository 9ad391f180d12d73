"""The role a task is addressed to, in the agent's program and on the wire.

In AgentSpeak the first argument of an environment action names a robot, or a role:
`any(Capabilities)` or `any(Capabilities, at(Lat, Lon))` (`ROLE_FUNCTOR`,
`PLACE_FUNCTOR`), e.g. `cover(any([uav, camera], at(48.2, 16.3)), g7, Area)`. On the
wire it is `ActionRequest.role`: {"capabilities": [...], "near": [lat, lon]}, with no
robot; the RCL awards the task to one robot (mrss.actors.rcl.allocation).
"""

from __future__ import annotations

ROLE_FUNCTOR = "any"
PLACE_FUNCTOR = "at"
CAPABILITIES = "capabilities"
NEAR = "near"
