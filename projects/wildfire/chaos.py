"""The wildfire operator for `mrss chaos wildfire` (docs/chaos.md): what operator_console.py sends.

Every `every` seconds or so the operator draws a new area goal (a1, a2, ...) near one of
the hidden hotspots or elsewhere around home, small enough for a short cover; now and
then instead it cancels an earlier goal, changes one's priority, or takes one of the
UGVs into teleoperation and hands it back a little later (always both, in that order).
"""

from __future__ import annotations

import random
from collections.abc import Iterator
from typing import Any

PREFIX = "mrss/ui"                                  # [events] topic_prefix in project.toml
REPLY_TOPICS = [f"{PREFIX}/+/reply"]                  # [events] reply_topic "{topic}/reply"
PENDING_BELIEFS = ["on_hold", "task", "retrying"]  # agent.asl: a goal not ended
MODE_BELIEFS = {"teleop": "paused({robot},teleop)"}
HOME = (-35.363262, 149.165237)
SPOTS = [(-35.360567, 149.165237), (-35.361196, 149.164576), (-35.366500, 149.167500),
         (-35.365500, 149.169000), HOME]
DEG_PER_M = 1.0 / 111_320.0
UGVS = ("ugv1", "ugv2")                             # project.toml's [components.rcl.robots]


def operator_traffic(rng: random.Random, every: float) -> Iterator[dict[str, Any]]:
    """Endless operator steps (see mrss/chaos/traffic.py for their shape)."""
    goals: list[str] = []
    number = 0
    while True:
        pause = rng.uniform(0.5, 1.5) * every
        roll = rng.random()
        if goals and roll < 0.15:
            goal = rng.choice(goals)
            goals.remove(goal)
            yield {"after": pause, "intent": "cancel", "goal": goal,
                   "topic": f"{PREFIX}/cancel", "payload": {"goal": goal}}
        elif goals and roll < 0.30:
            goal, priority = rng.choice(goals), rng.randint(1, 9)
            yield {"after": pause, "intent": "priority", "goal": goal,
                   "topic": f"{PREFIX}/priority", "payload": {"goal": goal, "priority": priority}}
        elif roll < 0.45:
            robot = rng.choice(UGVS)
            for after, on in ((pause, True), (rng.uniform(0.3, 0.8) * every, False)):
                yield {"after": after, "intent": "mode", "robot": robot, "mode": "teleop",
                       "on": on, "topic": f"{PREFIX}/teleop",
                       "payload": {"robot": robot, "on": on}}
        else:
            number += 1
            goal = f"a{number}"
            goals.append(goal)
            lat, lon = rng.choice(SPOTS)
            lat += rng.uniform(-60, 60) * DEG_PER_M
            lon += rng.uniform(-60, 60) * DEG_PER_M
            yield {"after": pause, "intent": "goal", "goal": goal, "topic": f"{PREFIX}/area",
                   "payload": {"goal": goal, "priority": rng.randint(1, 5),
                               "center": [round(lat, 6), round(lon, 6)],
                               "radius": rng.choice([30, 40, 50])}}
