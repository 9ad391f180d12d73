"""The operator of `mrss chaos` on the fleetloss project: a sweep near one of the UAVs'
homes every so often (goals g1, g2, ...), addressed to any UAV with a camera."""

from __future__ import annotations

import random
from collections.abc import Iterator
from typing import Any

PENDING_BELIEFS = ["sweep_received"]
HOMES = [(-35.363262, 149.165237), (-35.363262, 149.169637)]


def operator_traffic(rng: random.Random, every: float) -> Iterator[dict[str, Any]]:
    number = 0
    while True:
        number += 1
        goal = f"g{number}"
        lat, lon = rng.choice(HOMES)
        yield {"after": rng.uniform(0.5, 1.5) * every, "intent": "goal", "goal": goal,
               "topic": "mrss/ui/sweep",
               "payload": {"goal": goal, "lat": lat, "lon": lon, "strips": 12}}
