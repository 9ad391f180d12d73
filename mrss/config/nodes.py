"""Nodes: the hosts one project runs on, and which component runs where.

A project without `[nodes]` runs on one host, as always. With

```toml
[nodes.base]
address = "10.0.0.1"      # where the other nodes reach this node's bus
port = 5710               # its inbox (tcp, CurveZMQ)
[nodes.field]
address = "10.0.0.2"
port = 5710

[components.rcl]
node = "base"             # a component without `node` runs on the first node declared
```

`mrss supervise PROJECT --node base` runs base's share (and the bus proxy, which runs
on every node). `read_nodes` validates it all and returns every problem with its dotted
key (`mrss check` turns them into findings at their line); `node_plan` raises the first
as a ConfigError (for `mrss supervise` and `mrss keys`).
"""

from __future__ import annotations

import ipaddress
from collections.abc import Mapping
from dataclasses import dataclass, field, replace
from pathlib import Path
from typing import Any

from mrss.config.kinds import ComponentKind
from mrss.config.loader import ID_PATTERN
from mrss.config.project import ProjectConfig
from mrss.errors import ConfigError
from mrss.supervision.children import ComponentStart
from mrss.supervision.spec import ChildSpec

NODE_KEYS = ("address", "port", "bind")
DEFAULT_KEYS_DIR = "keys"


@dataclass(frozen=True)
class Node:
    """One `[nodes.<name>]` table."""

    name: str
    address: str  # where peers connect to this node's inbox
    port: int
    bind: str  # the address the inbox binds (default: address)

    @property
    def endpoint(self) -> str:
        return _tcp(self.address, self.port)

    @property
    def bind_endpoint(self) -> str:
        return _tcp(self.bind, self.port)


@dataclass(frozen=True)
class NodeProblem:
    """Something wrong in the node layout: the dotted key it is at, and what."""

    key: str
    message: str


@dataclass(frozen=True)
class NodePlan:
    """The validated layout: nodes in file order, and the node of every component."""

    nodes: dict[str, Node] = field(default_factory=dict)
    placement: dict[str, str] = field(default_factory=dict)  # component id -> node
    robots: dict[str, str] = field(default_factory=dict)  # robot id -> node behind which

    @property
    def multi(self) -> bool:
        return bool(self.nodes)

    def components_on(self, node: str) -> list[str]:
        """The component ids `node` runs (the bus proxy included: it runs on every node)."""
        return [c for c, n in self.placement.items() if n == node or n == ""]

    def check_node(self, name: str) -> Node:
        """The node called `name`, or a ConfigError with a did-you-mean."""
        if name not in self.nodes:
            raise ConfigError(f"no node {name!r}" + _hint(name, tuple(self.nodes)), key="node")
        return self.nodes[name]


def read_nodes(config: ProjectConfig) -> tuple[NodePlan, list[NodeProblem]]:
    """The node layout of a loaded project, and every problem in it."""
    problems: list[NodeProblem] = []
    raw = config.sections.get("nodes")
    nodes: dict[str, Node] = {}
    if raw is not None and not isinstance(raw, Mapping):
        problems.append(NodeProblem("nodes", "must be a table of [nodes.<name>] tables"))
    elif raw is not None:
        for name, table in raw.items():
            node = _node(str(name), table, problems)
            if node is not None:
                nodes[node.name] = node
        seen: dict[tuple[str, int], str] = {}
        for node in nodes.values():
            other = seen.setdefault((node.address, node.port), node.name)
            if other != node.name:
                problems.append(NodeProblem(
                    f"nodes.{node.name}.port", f"node {other!r} has the same address and "
                    f"port ({node.address}:{node.port}); each node needs its own"))
    # every declared name counts as known, also one whose table has a problem of its own
    names = tuple(str(n) for n in raw) if isinstance(raw, Mapping) else ()
    placement: dict[str, str] = {}
    for comp in config.enabled():
        key = f"components.{comp.id}.node"
        if comp.kind is ComponentKind.BUS:
            if comp.node:
                problems.append(NodeProblem(key, "the bus proxy runs on every node; "
                                                 "remove 'node' here"))
            placement[comp.id] = ""
            continue
        placement[comp.id] = _place(comp.node, key, names, raw is not None, problems)
    robots: dict[str, str] = {}
    for comp in config.enabled():
        table = comp.options.get("robots") if comp.kind is ComponentKind.RCL else None
        if not isinstance(table, Mapping):
            continue
        for robot, options in table.items():
            if isinstance(options, Mapping) and "node" in options:
                key = f"components.{comp.id}.robots.{robot}.node"
                if not isinstance(options["node"], str):
                    problems.append(NodeProblem(key, f"must be a node name, not "
                                                     f"{options['node']!r}"))
                    continue
                robots[str(robot)] = _place(options["node"], key, names, raw is not None,
                                            problems)
    return NodePlan(nodes, placement, robots), problems


def node_plan(config: ProjectConfig) -> NodePlan:
    """The validated layout; ConfigError (file, line, key) for the first problem."""
    plan, problems = read_nodes(config)
    if problems:
        from mrss.config.key_lines import key_line_number

        first = problems[0]
        line = key_line_number(config.file, first.key)
        raise ConfigError(first.message, file=f"{config.file}:{line}" if line
                          else str(config.file), key=first.key)
    return plan


def node_children(config: ProjectConfig, plan: NodePlan,
                  node: str) -> list[ChildSpec[ComponentStart]]:
    """The root supervisor's children on `node`: its components in file order, and the
    bus proxy given the mesh settings (mrss.bus.mesh) that make it this node's proxy."""
    me = plan.check_node(node)
    bus = config.sections.get("bus", {})
    bus = bus if isinstance(bus, Mapping) else {}
    components = {n: [c for c, at in plan.placement.items() if at == n] for n in plan.nodes}
    from mrss.bus.mesh import MeshSettings  # the mesh (asyncio, CurveZMQ) for [nodes] only

    mesh = MeshSettings(
        node=node, inbox=me.bind_endpoint, keys_dir=str(keys_dir(config)),
        peers={n.name: n.endpoint for n in plan.nodes.values() if n.name != node},
        components=components, interval=float(bus.get("node_heartbeat", 0.5)),
        misses=int(bus.get("node_misses", 4)),
        max_skew=float(bus.get("max_clock_skew", 5.0))).to_dict()
    children = []
    for comp in config.enabled():
        if comp.kind is ComponentKind.BUS:
            comp = replace(comp, options={**comp.options, "mesh": mesh})
        elif plan.placement.get(comp.id) != node:
            continue
        children.append(comp.child_spec())
    return children


def keys_dir(config: ProjectConfig) -> Path:
    """Where the nodes' CurveZMQ keys live: `[bus] keys_dir`, relative to the project."""
    bus = config.sections.get("bus", {})
    name = bus.get("keys_dir", DEFAULT_KEYS_DIR) if isinstance(bus, Mapping) else \
        DEFAULT_KEYS_DIR
    return config.directory / str(name)


def _node(name: str, table: Any, problems: list[NodeProblem]) -> Node | None:
    key = f"nodes.{name}"
    if not ID_PATTERN.match(name):
        problems.append(NodeProblem(key, "a node name starts with a letter and holds only "
                                         "letters, digits, '_', '-' and '.'"))
        return None
    if not isinstance(table, Mapping):
        problems.append(NodeProblem(key, "must be a table with address and port"))
        return None
    ok = True
    for k in table:
        if k not in NODE_KEYS:
            problems.append(NodeProblem(f"{key}.{k}", "unknown key" + _hint(str(k), NODE_KEYS)))
            ok = False
    address = table.get("address")
    if not isinstance(address, str) or not _ip(address):
        problems.append(NodeProblem(f"{key}.address", f"must be an IP address, not {address!r}"))
        ok = False
    port = table.get("port")
    if isinstance(port, bool) or not isinstance(port, int) or not 0 < port < 65536:
        problems.append(NodeProblem(f"{key}.port", f"must be a port 1-65535, not {port!r}"))
        ok = False
    bind = table.get("bind", address)
    if not isinstance(bind, str) or not _ip(bind):
        problems.append(NodeProblem(f"{key}.bind", f"must be an IP address, not {bind!r}"))
        ok = False
    if not ok:
        return None
    return Node(name, str(address), int(port), str(bind))  # type: ignore[arg-type]


def _place(wanted: str, key: str, names: tuple[str, ...], declared: bool,
           problems: list[NodeProblem]) -> str:
    if not wanted:
        return names[0] if names else ""
    if not declared:
        problems.append(NodeProblem(key, f"node {wanted!r}, but the project declares no "
                                         "[nodes] (add [nodes.<name>] tables, docs/config.md)"))
        return ""
    if wanted not in names:
        problems.append(NodeProblem(key, f"no node {wanted!r}" + _hint(wanted, names)))
        return names[0] if names else ""
    return wanted


def _hint(word: str, options: tuple[str, ...]) -> str:
    import difflib

    close = difflib.get_close_matches(word, options, n=1, cutoff=0.6)
    if close:
        return f"; did you mean {close[0]!r}?"
    return f"; known: {', '.join(options)}" if options else ""


def _ip(text: str) -> bool:
    try:
        ipaddress.ip_address(text)
    except ValueError:
        return False
    return True


def _tcp(host: str, port: int) -> str:
    return f"tcp://[{host}]:{port}" if ":" in host else f"tcp://{host}:{port}"


def root_children(config: ProjectConfig, node: str) -> list[ChildSpec[ComponentStart]]:
    """The root's children: the project's components, or one node's share of them."""
    return node_children(config, node_plan(config), node) if node else config.child_specs()
