"""What the root supervisor tells a component process it starts: the start context.

The root builds one per start and hands it over as JSON (`--context`); the process reads
it back as a `mrss.runtime.component.ComponentContext`, which adds what a running
component does with it (its logger, its bus publisher, asking to stop).
"""

from __future__ import annotations

import json
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Self

from mrss.errors import SupervisionError


@dataclass
class StartContext:
    """Who a component is, where it runs, how to reach the bus: what it knows at start.

    `incarnation` goes up by one at every start of this component; messages it sends
    carry it (`inc`) so that a dead incarnation's late messages can be dropped.
    `bus` holds the endpoints as `mrss.bus.BusEndpoints.to_dict()` gives them.
    `options` are the component's free keys from project.toml.
    """

    name: str
    incarnation: int
    project_dir: Path
    run_dir: Path
    bus: dict[str, Any] = field(default_factory=dict)
    options: dict[str, Any] = field(default_factory=dict)
    heartbeat_interval: float = 0.5
    faults: dict[str, Any] = field(default_factory=dict)
    scheduling: dict[str, Any] = field(default_factory=dict)  # {"nice": n, "cpus": [...]}

    def to_json(self) -> str:
        """The --context argument of the component's process."""
        return json.dumps({
            "project_dir": str(self.project_dir), "run_dir": str(self.run_dir),
            "bus": self.bus, "options": self.options,
            "heartbeat_interval": self.heartbeat_interval, "faults": self.faults,
            "scheduling": self.scheduling,
        })

    @classmethod
    def from_json(cls, name: str, incarnation: int, text: str) -> Self:
        try:
            data = json.loads(text)
            return cls(
                name=name, incarnation=incarnation, project_dir=Path(data["project_dir"]),
                run_dir=Path(data["run_dir"]), bus=dict(data.get("bus") or {}),
                options=dict(data.get("options") or {}),
                heartbeat_interval=float(data.get("heartbeat_interval", 0.5)),
                faults=dict(data.get("faults") or {}),
                scheduling=dict(data.get("scheduling") or {}),
            )
        except (ValueError, KeyError, TypeError) as exc:
            raise SupervisionError(f"component {name}: bad --context: {exc}") from exc
