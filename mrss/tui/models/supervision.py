"""The supervision tree as the TUI knows it: built from `sup.*` events and `sup.tree` snapshots.

A node's path is its supervisor's path plus its id: `wildfire/rcl` for a component of
the root supervisor `wildfire`. Actor supervisors inside a component name themselves
without the component (`robots/uav1`), so their events are placed under the component
that published them (the envelope's `src`): `wildfire/rcl/robots/uav1`.
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass, field
from typing import Any

from mrss.messages import SupEvent

# The `src` of the root supervisor's publisher in `mrss supervise`.
ROOT_SRC = "supervisor"
TREE_EVENT = "tree"


@dataclass
class SupNode:
    """One supervised child (or supervisor) and what was last heard of it."""

    path: str
    parent: str  # the parent's path; "" for a root
    kind: str = "worker"
    state: str = "?"
    pid: int = 0
    incarnation: int = 0
    restarts: int = 0
    up_since: float | None = None  # wall-clock time it last started (running only)
    last_reason: str = ""
    restart_times: list[float] = field(default_factory=list)  # seen while attached

    def budget_text(self, now: float, intensity: int, period: float) -> str:
        """`4 of 5 in 30 s`: restarts seen within the last `period` against the budget."""
        recent = sum(1 for t in self.restart_times if now - t <= period)
        return f"{recent} of {intensity} in {period:g} s"

    @property
    def name(self) -> str:
        return self.path.rsplit("/", 1)[-1]

    @property
    def depth(self) -> int:
        return self.path.count("/")

    def uptime(self, now: float) -> float | None:
        """Seconds since it started, while it runs."""
        if self.state != "running" or self.up_since is None:
            return None
        return max(0.0, now - self.up_since)


class SupervisionModel:
    """Every node heard of, by path; `rows()` lists them depth-first in the order heard."""

    def __init__(self, root: str = "") -> None:
        self.root = root  # the root supervisor's name (the project's), once known
        self.nodes: dict[str, SupNode] = {}

    def apply_event(self, event: SupEvent, src: str, ts: float) -> None:
        """Update the tree for one `sup.<event>` sent by `src` at wall-clock `ts`."""
        if event.event == TREE_EVENT:
            tree = event.detail.get("tree")
            if isinstance(tree, dict):
                self.apply_tree(tree, ts)
            return
        if src == ROOT_SRC and not self.root and "/" not in event.supervisor:
            self.root = event.supervisor
        base = self._component_path(src)
        parent = base
        for part in event.supervisor.split("/") if event.supervisor else ():
            parent = f"{parent}/{part}" if parent else part
            self._ensure(parent).kind = "supervisor"  # every segment is a supervisor
        node = self._ensure(f"{parent}/{event.child}" if parent else event.child)
        kind = event.event
        if kind == "start":
            node.state, node.pid, node.up_since = "running", event.pid, ts
            inc = event.detail.get("inc")
            if isinstance(inc, int) and not isinstance(inc, bool):
                node.incarnation = inc
        elif kind == "exit":
            node.state = "stopped" if event.reason.startswith("shutdown") else "exited"
            node.pid, node.up_since, node.last_reason = 0, None, event.reason
            self._gone_with(node)
        elif kind == "restart":
            node.state, node.restarts = "waiting", event.count
            node.restart_times.append(ts)
            del node.restart_times[:-100]
            node.last_reason = event.reason or node.last_reason
        elif kind == "hang":
            node.state, node.last_reason = "hung", event.reason
        elif kind == "quarantine":
            node.state, node.pid, node.up_since = "quarantined", 0, None
            node.last_reason = event.reason or node.last_reason
        elif kind == "release":
            node.state = "waiting"
        elif kind == "give_up" and event.detail.get("stops") == "component":
            # the root stopped only this component (and its group): the rest runs on
            members = event.detail.get("members")
            for member in members if isinstance(members, list) else [event.child]:
                other = self._ensure(f"{parent}/{member}" if parent else str(member))
                other.state, other.pid, other.up_since = "gave up", 0, None
            node.last_reason = event.reason or node.last_reason
        elif kind in ("escalate", "give_up"):
            node.last_reason = event.reason or node.last_reason
            if parent:
                self._ensure(parent).state = "escalated" if kind == "escalate" else "gave up"

    def apply_tree(self, tree: Mapping[str, Any], ts: float, parent: str = "") -> None:
        """Replace what is known with a `ChildStatus.to_dict()` snapshot taken at `ts`."""
        ident = tree.get("id")
        if not isinstance(ident, str) or not ident:
            return
        if not parent:
            self.root = ident
        node = self._ensure(f"{parent}/{ident}" if parent else ident)
        node.kind = _text(tree, "kind", node.kind)
        node.state = _text(tree, "state", node.state)
        node.pid = _number(tree, "pid", 0)
        node.incarnation = _number(tree, "incarnation", node.incarnation)
        node.restarts = _number(tree, "restarts", node.restarts)
        node.last_reason = _text(tree, "last_reason", node.last_reason)
        uptime = tree.get("uptime")
        # the root reports no uptime of its own (0.0): show none rather than "0s"
        running = node.state == "running" and isinstance(uptime, (int, float)) and uptime > 0
        node.up_since = ts - float(uptime) if running else None  # type: ignore[arg-type]
        children = tree.get("children")
        if isinstance(children, list):
            for child in children:
                if isinstance(child, dict):
                    self.apply_tree(child, ts, node.path)

    def rows(self) -> list[SupNode]:
        """The nodes depth-first, each after its parent, siblings in the order first heard."""
        kids: dict[str, list[SupNode]] = {}
        for node in self.nodes.values():
            kids.setdefault(node.parent, []).append(node)
        out: list[SupNode] = []

        def walk(parent: str) -> None:
            for node in kids.get(parent, []):
                out.append(node)
                walk(node.path)

        walk("")
        return out

    def is_component(self, path: str) -> bool:
        """Whether `path` is a process child of the root supervisor (faults reach those)."""
        node = self.nodes.get(path)
        return node is not None and bool(self.root) and node.parent == self.root

    def _gone_with(self, node: SupNode) -> None:
        """A process exited: the actors it ran (nodes below it) are gone with it."""
        prefix = node.path + "/"
        for other in self.nodes.values():
            if other.path.startswith(prefix) and other.state not in ("stopped", "exited"):
                other.state, other.pid, other.up_since = "stopped", 0, None
                other.last_reason = f"{node.name} exited"

    def _component_path(self, src: str) -> str:
        """Where the supervisors of a message from `src` hang: "" for the root's own."""
        if src == ROOT_SRC or not src:
            return ""
        return f"{self.root}/{src}" if self.root else src

    def _ensure(self, path: str, kind: str = "worker") -> SupNode:
        node = self.nodes.get(path)
        if node is None:
            parent = path.rsplit("/", 1)[0] if "/" in path else ""
            if parent:
                self._ensure(parent, "supervisor")  # a node heard of before its supervisor
            node = self.nodes[path] = SupNode(path, parent, kind)
        return node


def _text(data: Mapping[str, Any], key: str, default: str) -> str:
    value = data.get(key)
    return value if isinstance(value, str) else default


def _number(data: Mapping[str, Any], key: str, default: int) -> int:
    value = data.get(key)
    return value if isinstance(value, int) and not isinstance(value, bool) else default
