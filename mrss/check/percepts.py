"""Percepts the project produces vs the belief events agent.asl reacts to (warnings only).

Produced: every `JsonMapping("functor", Field, ...)` and `self.percept("functor", ...)` of
events.py (read with `ast`, arity from the fields or arguments), the world model rules'
functors of project.toml, MRSS's own `robot_unavailable/1` and `reassigned/3` (the RCL's,
when a task addressed to a role goes to another robot), and the geofence's
`geofence_exit/4` and `geofence_trapped/2` when `[datalayer] geofence` is on. Rules:
- a percept events.py declares that no `+functor(...)`/`-functor(...)` plan of the agent
  handles (same arity) is a warning at its line in events.py;
- a `+b[source(percept)]` plan for a percept nothing produces is a warning at its line in
  agent.asl, unless the name is a string anywhere in events.py or datalayer.py (a
  percept whose name is computed there; those cannot be told apart statically);
- the geofence on without a `+geofence_exit(...)` plan is a warning: a robot found
  inside a no-go zone would only be alerted, never driven out.
"""

from __future__ import annotations

import ast
from dataclasses import dataclass
from pathlib import Path

from mrss.actors.datalayer.geofence import EXIT, TRAPPED, Geofence
from mrss.check.agent import AgentUses
from mrss.check.findings import Report, did_you_mean
from mrss.check.sources import PySource
from mrss.config.project import ProjectConfig

BUILTIN = {("robot_unavailable", 1), ("reassigned", 3)}


@dataclass(frozen=True)
class Produced:
    name: str
    arity: int | None  # None: unknown (a percept built from a text)
    file: Path
    line: int


def produced_by(source: PySource) -> list[Produced]:
    """The percepts a project file declares (JsonMapping) or publishes (percept calls)."""
    found: list[Produced] = []
    if source.tree is None:
        return found
    for node in ast.walk(source.tree):
        if not isinstance(node, ast.Call) or not node.args:
            continue
        first = node.args[0]
        if not (isinstance(first, ast.Constant) and isinstance(first.value, str)):
            continue
        callee = ast.unparse(node.func)
        if callee.endswith("JsonMapping"):
            found.append(Produced(first.value, len(node.args) - 1, source.path, node.lineno))
        elif callee.endswith(".percept"):
            name, _, rest = first.value.partition("(")
            arity = None if rest else len(node.args) - 1
            found.append(Produced(name.strip(), arity, source.path, node.lineno))
    return found


def strings_in(source: PySource | None) -> set[str]:
    if source is None or source.tree is None:
        return set()
    return {n.value for n in ast.walk(source.tree)
            if isinstance(n, ast.Constant) and isinstance(n.value, str)}


def rule_functors(config: ProjectConfig) -> set[str]:
    rules = (config.sections.get("worldmodel") or {}).get("rules") or []
    return {str(r.get("functor", f"{r.get('kind')}_detected")) for r in rules
            if isinstance(r, dict)}


def check_percepts(config: ProjectConfig, uses: AgentUses, events: PySource | None,
                   datalayer: PySource | None, report: Report, *,
                   also: set[str] | frozenset[str] = frozenset()) -> None:
    """`also`: percepts produced elsewhere (the declared operator commands)."""
    produced = produced_by(events) if events is not None else []
    handled = {(t.name, t.arity) for t in uses.triggers}
    handled_names = {t.name for t in uses.triggers}
    fenced = Geofence.on(config.sections.get("datalayer") or {})
    if fenced and (EXIT, 4) not in handled:
        report.warning(str(uses.file), f"[datalayer] geofence is on but agent.asl has no "
                       f"+{EXIT}(Robot, Zone, Lat, Lon) plan: a robot found stopped inside a "
                       "no-go zone is only alerted, never driven out", check="percepts")
    for p in produced:
        if (p.name, p.arity) in handled or (p.arity is None and p.name in handled_names):
            continue
        report.warning(str(p.file), f"percept {p.name}/{p.arity} is never handled: agent.asl "
                       f"has no +{p.name}(...) plan"
                       + (f" of arity {p.arity}" if p.name in handled_names else
                          did_you_mean(p.name, handled_names, what="it handles")),
                       line=p.line, check="percepts")
    if events is None or events.tree is None:
        return  # what events.py produces is unknown: no warning on the agent's side
    names = {p.name for p in produced} | rule_functors(config) | {b[0] for b in BUILTIN} \
        | strings_in(events) | strings_in(datalayer) | set(also) \
        | ({EXIT, TRAPPED} if fenced else set())
    for trigger in uses.triggers:
        if trigger.name in names or not trigger.from_percept:
            continue
        names.add(trigger.name)  # one warning per name
        report.warning(str(uses.file), f"+{trigger.name}/{trigger.arity}[source(percept)]: no "
                       "part of the project produces this percept (events.py, datalayer.py, "
                       "world model rules)" + did_you_mean(trigger.name,
                                                           {p.name for p in produced},
                                                           what="events.py produces"),
                       line=trigger.line, check="percepts")
