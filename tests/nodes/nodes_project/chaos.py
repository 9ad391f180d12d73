"""The operator of `mrss chaos` on the nodes project: a patrol of ugv1 every so often."""

from __future__ import annotations

import random
from collections.abc import Iterator
from typing import Any

PENDING_BELIEFS = ["patrol_received"]


def operator_traffic(rng: random.Random, every: float) -> Iterator[dict[str, Any]]:
    number = 0
    while True:
        number += 1
        goal = f"g{number}"
        yield {"after": rng.uniform(0.5, 1.5) * every, "intent": "goal", "goal": goal,
               "topic": "mrss/ui/patrol", "payload": {"goal": goal, "robot": "ugv1"}}
