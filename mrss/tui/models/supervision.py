"""The supervision tree as the TUI knows it: built from `sup.*` events and `sup.tree` snapshots.

A node's path is its supervisor's path plus its id: `wildfire/rcl` for a component of
the root supervisor `wildfire`. Actor supervisors inside a component name themselves
without the component (`robots/uav1`), so their events are placed under the component
that published them (the envelope's `src`): `wildfire/rcl/robots/uav1`.

On several hosts (`[nodes]`) every event carries its node, and the tree has a level per
node: `wildfire/base/rcl/robots/uav1`. A node lost (`sup.node_down` from this node's bus
proxy) marks its level and its components "node down" with the reason; `sup.node_up`
gives them back the states they had.

A component's `refused` is the total of its latest `Rejections` report (the input it
refused since it started; 0 again when it starts anew).
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass, field
from typing import Any

from mrss.messages import Rejections, SupEvent, within_run
from mrss.supervision.nodes import NODE_DOWN, NODE_UP

# The `src` of the root supervisor's publisher in `mrss supervise`.
ROOT_SRC = "supervisor"
TREE_EVENT = "tree"
STOPPING = "stopping"  # mrss.supervision.events.STOPPING
NODE_KIND = "node"  # the kind of a node's level in the tree
NODE_DOWN_STATE = "node down"


ENDED_STATES = ("stopped", "exited", "gave up")  # a node in one of these is not running


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
    refused: int = 0  # input refused by this incarnation (its Rejections reports)
    restart_times: list[float] = field(default_factory=list)  # seen while attached
    # (restarts in the window, limit, window s) as its supervisor last reported it
    budget: tuple[int, int, float] | None = None
    restarts_at_tree: int = 0  # `restarts` when that budget was reported

    def budget_text(self, now: float, intensity: int, period: float) -> str:
        """`4 of 5 in 30 s`: the supervisor's own count when its tree reported one, else
        the restarts seen within the last `period` against the configured budget."""
        if self.budget is not None:
            used, limit, window = self.budget
            return f"{used} of {limit} in {window:g} s"
        recent = sum(1 for t in self.restart_times if now - t <= period)
        return f"{recent} of {intensity} in {period:g} s (seen since attached)"

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
    """Every node heard of, by path; `rows()` lists them depth-first, siblings in their
    supervisor's order (the order heard until a tree came)."""

    def __init__(self, root: str = "") -> None:
        self.root = root  # the root supervisor's name (the project's), once known
        self.nodes: dict[str, SupNode] = {}
        self._before_down: dict[str, str] = {}  # a component's state before its node was lost

    def apply_event(self, event: SupEvent, src: str, ts: float) -> None:
        """Update the tree for one `sup.<event>` sent by `src` at wall-clock `ts`."""
        if event.event == TREE_EVENT:
            tree = event.detail.get("tree")
            if isinstance(tree, dict):
                # the root's tree, or a component's own (the RCL's robot actors), under it
                own = event.detail.get("scope") == "component"
                base = self._component_path(src, event.node) if own else ""
                if base:
                    self._ensure(base)
                    self.apply_tree(tree, ts, base)
                else:
                    self.apply_tree(tree, ts, node=event.node)
            return
        if event.event in (NODE_DOWN, NODE_UP):
            self._node_state(event)
            return
        if event.event == STOPPING:
            return  # about the supervisor itself; its children's exits follow
        if src == ROOT_SRC and not self.root and "/" not in event.supervisor:
            self.root = event.supervisor
        base = self._component_path(src, event.node)
        parent = base
        for part in event.supervisor.split("/") if event.supervisor else ():
            parent = f"{parent}/{part}" if parent else part
            self._ensure(parent).kind = "supervisor"  # every segment is a supervisor
            if not base and event.node and parent == self.root:  # the root's node level
                parent = f"{parent}/{event.node}"
                self._ensure(parent).kind = NODE_KIND
        node = self._ensure(f"{parent}/{event.child}" if parent else event.child)
        kind = event.event
        if kind == "start":
            node.state, node.pid, node.up_since = "running", event.pid, ts
            node.refused = 0
            inc = event.detail.get("inc")
            if isinstance(inc, int) and not isinstance(inc, bool):
                node.incarnation = within_run(inc)  # a peer node's: as its own root counts
        elif kind == "exit":
            node.state = "stopped" if event.reason.startswith("shutdown") else "exited"
            node.pid, node.up_since, node.last_reason = 0, None, event.reason
            self._gone_with(node)
        elif kind == "restart":
            node.state, node.restarts = "waiting", event.count
            node.restart_times.append(ts)
            del node.restart_times[:-100]
            if node.budget is not None and event.count > node.restarts_at_tree:
                # counted by its supervisor since its last tree (the next tree corrects
                # the few causes it does not count, e.g. a lost link)
                used, limit, window = node.budget
                node.budget = used + event.count - node.restarts_at_tree, limit, window
                node.restarts_at_tree = event.count
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

    def apply_rejections(self, report: Rejections) -> None:
        """A component's refusal counters (`edge.rejections.<component>`); ignored until
        the root is known (the report is repeated), so it lands under the right node."""
        if not report.component or not self.root:
            return
        # on several hosts the component sits under its node's level: where it is known
        known = [p for p, n in self.nodes.items() if p.startswith(f"{self.root}/")
                 and p.rsplit("/", 1)[-1] == report.component and n.kind != NODE_KIND
                 and p.count("/") <= 2]
        path = min(known, key=len) if known else self._component_path(report.component)
        self._ensure(path).refused = report.total

    def apply_tree(self, tree: Mapping[str, Any], ts: float, parent: str = "",
                   node: str = "") -> None:
        """Replace what is known with a `ChildStatus.to_dict()` snapshot taken at `ts`
        (of the root of `node`: its children go under that node's level)."""
        ident = tree.get("id")
        if not isinstance(ident, str) or not ident:
            return
        if not parent:
            self.root = ident
            if node:
                self._ensure(f"{ident}/{node}").kind = NODE_KIND
                children = tree.get("children")
                for child in children if isinstance(children, list) else ():
                    if isinstance(child, dict):
                        self.apply_tree(child, ts, f"{ident}/{node}")
                return
        node_ = self._ensure(f"{parent}/{ident}" if parent else ident)
        self._apply_status(node_, tree, ts)

    def _apply_status(self, node: SupNode, tree: Mapping[str, Any], ts: float) -> None:
        node.kind = _text(tree, "kind", node.kind)
        node.state = _text(tree, "state", node.state)
        node.pid = _number(tree, "pid", 0)
        node.incarnation = _number(tree, "incarnation", node.incarnation)
        node.restarts = _number(tree, "restarts", node.restarts)
        node.last_reason = _text(tree, "last_reason", node.last_reason)
        node.budget = _budget(tree.get("budget"), node.budget)
        node.restarts_at_tree = node.restarts
        uptime = tree.get("uptime")
        # the root reports no uptime of its own (0.0): show none rather than "0s"
        running = node.state == "running" and isinstance(uptime, (int, float)) and uptime > 0
        node.up_since = ts - float(uptime) if running else None  # type: ignore[arg-type]
        children = tree.get("children")
        if isinstance(children, list):
            for child in children:
                if isinstance(child, dict):
                    self.apply_tree(child, ts, node.path)
            # siblings in the supervisor's order (its start order), whatever came first
            for child in children:
                path = f"{node.path}/{child.get('id')}" if isinstance(child, dict) else ""
                if path in self.nodes:
                    self.nodes[path] = self.nodes.pop(path)

    def rows(self) -> list[SupNode]:
        """The nodes depth-first, each after its parent; siblings in their supervisor's
        order once a tree of it came, before that in the order first heard."""
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
        """Whether `path` is a process child of a root supervisor (faults reach those)."""
        node = self.nodes.get(path)
        if node is None or not self.root or node.kind == NODE_KIND:
            return False
        level = self.nodes.get(node.parent)
        return node.parent == self.root or (level is not None and level.kind == NODE_KIND
                                            and level.parent == self.root)

    def system_stopped(self) -> None:
        """The whole system stopped: every component (and supervisor) is shown stopped,
        not in the state last heard; one that had ended otherwise keeps how it ended."""
        for node in self.nodes.values():
            if node.state not in ENDED_STATES:
                node.state, node.pid, node.up_since = "stopped", 0, None

    def _node_state(self, event: SupEvent) -> None:
        """This node's proxy saw a peer node lost or back: its level and components."""
        if not self.root:
            return
        level = self._ensure(f"{self.root}/{event.child}", NODE_KIND)
        level.kind = NODE_KIND
        state = event.detail.get("state")
        level.state = state if isinstance(state, str) else event.event
        level.last_reason = event.reason
        listed = event.detail.get("components")
        for name in listed if isinstance(listed, list) else ():
            self._ensure(f"{level.path}/{name}")
        for child in [n for n in self.nodes.values() if n.parent == level.path]:
            if event.event == NODE_DOWN:
                if child.state != NODE_DOWN_STATE:
                    self._before_down[child.path] = child.state
                child.state, child.last_reason = NODE_DOWN_STATE, event.reason
            elif child.state == NODE_DOWN_STATE:
                child.state = self._before_down.pop(child.path, "?")

    def _gone_with(self, node: SupNode) -> None:
        """A process exited: the actors it ran (nodes below it) are gone with it."""
        prefix = node.path + "/"
        for other in self.nodes.values():
            if other.path.startswith(prefix) and other.state not in ("stopped", "exited"):
                other.state, other.pid, other.up_since = "stopped", 0, None
                other.last_reason = f"{node.name} exited"

    def _component_path(self, src: str, node: str = "") -> str:
        """Where the supervisors of a message from `src` hang: "" for the root's own."""
        if src == ROOT_SRC or not src:
            return ""
        if node and self.root:
            self._ensure(f"{self.root}/{node}").kind = NODE_KIND
            return f"{self.root}/{node}/{src}"
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


def _budget(value: Any, old: tuple[int, int, float] | None) -> tuple[int, int, float] | None:
    """A reported `[used, limit, period]`, or what was known when it is missing or bad."""
    if not isinstance(value, list) or len(value) != 3:
        return old
    used, limit, period = value
    numbers = all(isinstance(v, (int, float)) and not isinstance(v, bool) for v in value)
    if not numbers or used < 0 or limit < 0 or not period > 0:
        return old
    return int(used), int(limit), float(period)
