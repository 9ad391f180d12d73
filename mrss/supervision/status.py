"""The live supervision tree as plain data, for the TUI and `mrss supervise` queries."""

from __future__ import annotations

from dataclasses import dataclass, field
from enum import StrEnum
from typing import Any


class ChildState(StrEnum):
    """Where a child is in its life, as a supervisor sees it."""

    STARTING = "starting"  # started, not yet ready
    RUNNING = "running"
    STOPPING = "stopping"  # asked to stop; killed when its shutdown time is up
    WAITING = "waiting"  # down, restart scheduled (backoff)
    QUARANTINED = "quarantined"  # taken out after too many failures; retried after probation
    STOPPED = "stopped"  # down for good (finished, temporary, or supervisor stopped)


@dataclass(frozen=True)
class ChildStatus:
    """One node of the tree: a worker, or a supervisor with its own children."""

    id: str
    kind: str
    state: str
    pid: int = 0
    incarnation: int = 0
    restarts: int = 0
    uptime: float = 0.0
    last_reason: str = ""
    strategy: str = ""
    children: tuple[ChildStatus, ...] = field(default_factory=tuple)
    # its restart budget as its supervisor counts it: (restarts within the window, the
    # limit, the window in seconds); None for the root, which has no parent to count
    budget: tuple[int, int, float] | None = None

    def to_dict(self) -> dict[str, Any]:
        """Plain dicts and lists only (JSON and msgpack safe)."""
        return {
            "id": self.id, "kind": self.kind, "state": self.state, "pid": self.pid,
            "incarnation": self.incarnation, "restarts": self.restarts,
            "uptime": round(self.uptime, 3), "last_reason": self.last_reason,
            "strategy": self.strategy, "children": [c.to_dict() for c in self.children],
            "budget": None if self.budget is None else list(self.budget),
        }

    def find(self, child_id: str) -> ChildStatus | None:
        """The node with this id, searching depth-first."""
        if self.id == child_id:
            return self
        for child in self.children:
            found = child.find(child_id)
            if found is not None:
                return found
        return None


@dataclass(frozen=True)
class Outcome:
    """How the root supervisor ended: stopped on request, or gave up on a child."""

    gave_up: bool
    child: str = ""
    reason: str = ""
    note: str = ""

    def __str__(self) -> str:
        if not self.gave_up:
            return "stopped"
        return f"gave up: child {self.child!r} failed ({self.reason}); {self.note}"
