"""The operator of `mrss chaos NAME` (docs/chaos.md): what this project's UI would send.

Every `every` seconds or so the operator sends robot1 to a point a few tens of metres
from home (goals g1, g2, ...); now and then instead it cancels an earlier goal.
ADAPT: your own operator's messages (events.py reads them).
"""

from __future__ import annotations

import random
from collections.abc import Iterator
from typing import Any

PREFIX = "mrss/ui"                                   # [events] topic_prefix in project.toml
# agent.asl believes goto_received(G, ...) from the goal's percept until !forget(G) ends
# it (reached, cancelled, failed for good): while it does, the goal is still pursued
# (waiting for the robot, driving, or retrying).
PENDING_BELIEFS = ["goto_received"]
HOME = (48.2082, 16.3738)            # [components.rcl.robots.robot1] home
DEG_PER_M = 1.0 / 111_320.0


def operator_traffic(rng: random.Random, every: float) -> Iterator[dict[str, Any]]:
    """Endless operator steps (see mrss/chaos/traffic.py for their shape)."""
    goals: list[str] = []
    number = 0
    while True:
        pause = rng.uniform(0.5, 1.5) * every
        if goals and rng.random() < 0.2:
            goal = goals.pop(rng.randrange(len(goals)))
            yield {"after": pause, "intent": "cancel", "goal": goal,
                   "topic": f"{PREFIX}/cancel", "payload": {"goal": goal}}
            continue
        number += 1
        goal = f"g{number}"
        goals.append(goal)
        lat, lon = HOME
        yield {"after": pause, "intent": "goal", "goal": goal, "topic": f"{PREFIX}/goto",
               "payload": {"goal": goal,
                           "lat": round(lat + rng.uniform(-40, 40) * DEG_PER_M, 6),
                           "lon": round(lon + rng.uniform(-40, 40) * DEG_PER_M, 6)}}
