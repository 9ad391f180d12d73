"""The order of `mrss check`'s checks, and what each needs from the ones before it.

1. project.toml tables and components: each enabled component's class imported, its
   options checked against its declaration (`options`);
2. agent.asl (`agent`): syntax, and what it uses;
3. skills.py, then rcl.py and its robots (`sources`, `recipes`, `robots`): an agent
   action without a recipe, a recipe's unknown skill, a hook with the wrong signature;
4. events.py and datalayer.py with their tables; the agent's queries against the data
   layer's functions; percepts against the agent's triggers (`percepts`);
5. the dashboard's tables (`operator`, `alerts`, `map`) and the operator traffic of
   `mrss chaos` (`chaos_traffic`: chaos.py).
A check whose input is broken is skipped (its input's error says why): no cascades.
"""

from __future__ import annotations

import importlib
from typing import Any

from mrss.actors.datalayer.layer import DataLayer
from mrss.actors.events.adapter import ExternalAdapter
from mrss.agentspeak.literals import is_atom_name
from mrss.api import RobotCommLayer, Skill
from mrss.check.agent import AgentUses, read_agent
from mrss.check.alerts import check_alerts
from mrss.check.chaos_traffic import check_chaos_traffic
from mrss.check.cross_file import ProjectFacts, check_cross_file
from mrss.check.exposure import check_broker_login, check_exposure
from mrss.check.findings import Report, did_you_mean
from mrss.check.map import check_map
from mrss.check.nodes import check_nodes
from mrss.check.operator import check_operator
from mrss.check.operator_commands import check_commands, command_functors
from mrss.check.operators import check_operators
from mrss.check.options import check_component, check_tables, check_values, declared_options
from mrss.check.percepts import check_percepts
from mrss.check.reasoner_agents import check_agents
from mrss.check.recipes import (
    check_actions,
    check_recipe_skills,
    check_skill_signatures,
    layer_actions,
)
from mrss.check.robots import check_robots
from mrss.check.sources import PySource, Sources
from mrss.check.toml_lines import key_line, section_key
from mrss.config.kinds import ComponentKind
from mrss.config.loader import COMPONENT_KEYS
from mrss.config.project import ComponentConfig, ProjectConfig
from mrss.errors import SupervisionError
from mrss.options import Option, option_names
from mrss.runtime.main import load_class

REASONER, EVENTS = ComponentKind.REASONER, ComponentKind.EVENTS
DATALAYER, RCL, WORLDMODEL = ComponentKind.DATALAYER, ComponentKind.RCL, ComponentKind.WORLDMODEL


def check_project(config: ProjectConfig) -> Report:
    """Every check on a loaded project.toml; nothing is started."""
    report = Report(config.name)
    sources = Sources(config.directory, report)
    for former in config.warnings:  # an earlier release's spelling: it runs, and says so
        report.warning(former.file, f"{former.key}: {former.what}; write {former.instead}",
                       line=former.line, check="config", key=former.key)
    check_tables(config, report)
    check_nodes(config, report)
    check_broker_login(config, report)
    classes = _component_classes(config, report)
    uses = _agent(config, report)
    skills = _skills(config, sources, report)
    layers = [_rcl(config, comp, sources, skills, uses, report)
              for comp in _running(config, RCL)]
    events = _edge(config, sources, report, classes, "events", EVENTS, ExternalAdapter,
                   "events.py")
    datalayer = _edge(config, sources, report, classes, "datalayer", DATALAYER, DataLayer,
                      "datalayer.py")
    _worldmodel(config, report, classes)
    agents = sorted({config.directory / str(c.options.get("agent", "agent.asl"))
                     for c in _running(config, REASONER)})
    operator = check_operator(config, report, events_running=bool(_running(config, EVENTS)),
                              agent_files=[a for a in agents if a.is_file()])
    if operator is not None:
        check_commands(config, report, operator, uses,
                       events_running=bool(_running(config, EVENTS)))
    check_operators(config, report, operator)
    check_chaos_traffic(config, report, agent_files=[a for a in agents if a.is_file()])
    check_alerts(config, report)
    check_map(config, report)
    if uses is not None:
        _queries(uses, datalayer, report)
        if events is not None:
            check_percepts(config, uses, events[0], datalayer[0] if datalayer else None,
                           report, also=command_functors(operator))
    check_cross_file(_facts(config, sources, uses, layers, datalayer), report)
    return report


def _running(config: ProjectConfig, kind: ComponentKind) -> list[ComponentConfig]:
    return list(config.of_kind(kind))


def _facts(config: ProjectConfig, sources: Sources, uses: AgentUses | None,
           layers: list[type[RobotCommLayer] | None],
           datalayer: tuple[PySource | None, type | None] | None) -> ProjectFacts:
    """What the cross-file rules need from the checks above."""
    robots: set[str] | None = set()
    capabilities: dict[str, frozenset[str]] = {}
    for comp in _running(config, RCL):
        table = comp.options.get("robots")
        robots |= set(table) if isinstance(table, dict) else set()  # type: ignore[operator]
        for robot, options in (table.items() if isinstance(table, dict) else ()):
            caps = options.get("capabilities") if isinstance(options, dict) else None
            capabilities[str(robot)] = frozenset(
                str(c) for c in caps) if isinstance(caps, list) else frozenset()
    if any(layer is None or layer.action_cb is not RobotCommLayer.action_cb
           for layer in layers) or not all(map(is_atom_name, robots or ())):
        robots = None  # unknown layer, its own action convention, or bad ids (reported)
    functions = None
    where = ""
    if datalayer is not None and isinstance(datalayer[1], type) \
            and issubclass(datalayer[1], DataLayer):
        cls = datalayer[1]
        functions = DataLayer.functions(cls.__new__(cls))
        where = datalayer[0].path.name if datalayer[0] else "the default DataLayer"
    return ProjectFacts(sources, uses, robots, f"{config.file.name} [components.<rcl>.robots]",
                        functions, where, capabilities)


def _component_classes(config: ProjectConfig, report: Report) -> dict[str, type]:
    classes: dict[str, type] = {}
    for comp in config.components:
        if not comp.enabled:
            continue
        key = f"components.{comp.id}.module"
        try:
            cls = load_class(comp.module, str(config.directory))
        except SupervisionError as exc:
            report.error(str(config.file), _missing_class(comp.module) or str(exc),
                         line=key_line(config, key), check="components", key=key)
            continue
        classes[comp.id] = cls
        ignore = ("robots",) if comp.kind is RCL else ()
        check_component(config, report, comp.id, cls, comp.options, ignore)
    return classes


def _missing_class(target: str) -> str | None:
    """`module defines no class X; did you mean Y?` when the module imports but lacks X."""
    module_name, _, class_name = target.partition(":")
    try:
        module = importlib.import_module(module_name)
    except Exception:  # the loader's own message says why it cannot be imported
        return None
    if hasattr(module, class_name):
        return None
    classes = [n for n, v in vars(module).items() if isinstance(v, type)
               and v.__module__ == module.__name__]
    return f"module {module_name!r} defines no class {class_name!r}" + did_you_mean(
        class_name, classes, what="it defines")


def _agent(config: ProjectConfig, report: Report) -> AgentUses | None:
    files = {str(c.options.get("agent", "agent.asl")) for c in _running(config, REASONER)
             if c.options.get("agents") is None}
    society: dict[str, list[str]] = {}  # file -> initial beliefs, of agents in a society
    for comp in _running(config, REASONER):
        for spec in check_agents(config, comp, report) or []:
            society.setdefault(spec.file, []).extend(spec.beliefs)
    if not files and not society and (config.directory / "agent.asl").is_file():
        files = {"agent.asl"}
        report.warning(str(config.directory / "agent.asl"), "no reasoner component runs it",
                       check="agent")
    uses = None
    for name in sorted(files | set(society)):
        path = config.directory / name
        if not path.is_file():
            continue  # the reasoner's `agent` option says so
        found = read_agent(path, report, _beliefs(config, name) + society.get(name, []),
                           society=name in society)
        if found is not None:
            uses = found if uses is None else uses.merged(found)
            report.summary.append(f"  agent {name}: {found.lines} lines, {found.beliefs} "
                                  f"initial beliefs, actions "
                                  f"{_names(found.actions)}, queries {_names(found.queries)}")
    return uses


def _beliefs(config: ProjectConfig, agent: str) -> list[str]:
    """The initial beliefs (option `beliefs`) of the reasoners that run `agent`."""
    found: list[str] = []
    for c in _running(config, REASONER):
        beliefs = c.options.get("beliefs", [])
        if str(c.options.get("agent", "agent.asl")) == agent and isinstance(beliefs, list):
            found += [b for b in beliefs if isinstance(b, str)]
    return found


def _names(uses: Any) -> str:
    return ", ".join(sorted({u.name + (f"/{u.arity}" if u.arity else "") for u in uses})) \
        or "none"


def _skills(config: ProjectConfig, sources: Sources, report: Report) -> PySource | None:
    if not (config.directory / "skills.py").is_file():
        return None
    skills = sources.load("skills.py", check="skills")
    if skills.module is not None:
        check_skill_signatures(skills, report)
        names = [c.__name__ for c in skills.classes(Skill)]
        report.summary.append(f"  skills skills.py: {', '.join(names) or '(no Skill subclass)'}")
    return skills


def _rcl(config: ProjectConfig, comp: ComponentConfig, sources: Sources,
         skills: PySource | None, uses: AgentUses | None,
         report: Report) -> type[RobotCommLayer] | None:
    """Check one RCL component; its layer class, if it loaded."""
    key = f"components.{comp.id}.layer"
    file_name, _, class_name = str(comp.options.get("layer", "") or "rcl.py").partition(":")
    line = key_line(config, key) if "layer" in comp.options else 0
    source = sources.load(file_name, check="rcl", key=key, key_file=str(config.file),
                          key_line=line)
    layer = None
    if source.module is not None:
        layer = sources.find_class(source, RobotCommLayer, class_name or None, check="rcl",
                                   key=key, key_file=str(config.file), key_line=line)
    declared = tuple(getattr(layer, "robot_settings", ()) or ())
    settings = {o.name: o for o in declared if isinstance(o, Option)}
    robots = check_robots(config, report, comp.id, comp.options.get("robots"),
                          set(option_names(declared)), settings)
    if layer is None:
        if source.module is not None or not source.broken:
            return None
        report.warning(str(source.path), "the agent's actions were not checked against the "
                       "RCL's recipes: fix the error above first", check="rcl")
        return None
    handled = layer_actions(layer, source, report)
    if uses is not None:
        check_actions(uses, handled, layer.__name__, file_name, report)
    if skills is not None and skills.broken:
        report.warning(str(source.path), "recipes' skills not checked: skills.py has an "
                       "error reported above", check="rcl")
    else:
        check_recipe_skills(handled, skills, source, report)
    report.summary.append(f"  rcl {file_name}: {layer.__name__}, actions {handled.describe()}"
                          f" (from {handled.how})")
    report.summary.append(f"  robots: {', '.join(robots)}")
    return layer


def _edge(config: ProjectConfig, sources: Sources, report: Report, classes: dict[str, type],
          section: str, kind: ComponentKind, base: type, default: str
          ) -> tuple[PySource | None, type | None] | None:
    """An edge component's table and the project class it runs: (source, class)."""
    comps = _running(config, kind)
    table = dict(config.sections.get(section, {}) or {})
    comp_id = comps[0].id if comps else None
    for comp in comps:
        table.update(comp.options)
    module = str(table.get("module", default))
    path = config.directory / module
    if not comps:
        if section in config.sections or path.is_file():
            report.warning(str(path if path.is_file() else config.file),
                           f"no {section} component runs it", check=section)
        return None
    source: PySource | None = None
    cls: type | None = None
    if path.is_file() or "module" in table:
        mkey = section_key(config, section, comp_id, "module")
        source = sources.load(module, check=section, key=mkey, key_file=str(config.file),
                              key_line=key_line(config, mkey))
        if source.module is not None:
            ckey = section_key(config, section, comp_id, "class")
            cls = sources.find_class(source, base, table.get("class"), check=section,
                                     key=ckey, key_file=str(config.file),
                                     key_line=key_line(config, ckey))
    elif base is DataLayer:
        cls = DataLayer
    component = classes.get(comp_id or "")
    if source is not None and (source.broken or cls is None):
        broken = path.name if source.broken else \
            f"its class ({section_key(config, section, comp_id, 'class')} in {config.file.name})"
        report.warning(str(config.file), f"[{section}] options not checked: "
                       f"{broken} has an error reported above", check=section)
    elif component is not None:
        check_values(config, report, table, declared_options(component, cls),
                     lambda n: section_key(config, section, comp_id, n),
                     owner=f"[{section}] ({component.__name__}"
                           + (f" and {cls.__name__}" if cls else "") + ")",
                     hints=COMPONENT_KEYS,
                     undeclaring=cls if cls is not None and cls is not base
                     and not _declares_options(cls, base) else None)
    if cls is not None:
        extra = ""
        if issubclass(cls, DataLayer):
            extra = ", functions " + ", ".join(sorted(cls.__new__(cls).functions()))
        report.summary.append(f"  {section} {module}: {cls.__name__}{extra}")
    return source, cls


def _declares_options(cls: type, base: type) -> bool:
    """Whether a project class (or a class between it and MRSS's base) declares OPTIONS."""
    return any("OPTIONS" in vars(k) for k in cls.__mro__[:cls.__mro__.index(base)])


def _worldmodel(config: ProjectConfig, report: Report, classes: dict[str, type]) -> None:
    comps = _running(config, WORLDMODEL)
    if not comps or comps[0].id not in classes:
        return
    table = dict(config.sections.get("worldmodel", {}) or {})
    table.update(comps[0].options)
    check_values(config, report, table, declared_options(classes[comps[0].id]),
                 lambda n: section_key(config, "worldmodel", comps[0].id, n),
                 owner="[worldmodel] (WorldModelComponent)", hints=COMPONENT_KEYS)
    check_exposure(config, report, table, comps[0].id)


def _queries(uses: AgentUses, datalayer: tuple[PySource | None, type | None] | None,
             report: Report) -> None:
    if datalayer is None:
        if uses.queries:
            first = uses.queries[0]
            report.error(str(uses.file), f"query({first.name}, ...): no datalayer component "
                         "runs, so no query can be answered", line=first.line, col=first.col,
                         check="queries")
        return
    source, cls = datalayer
    if cls is None:
        return  # its own error says why
    functions = set(DataLayer.functions(cls.__new__(cls))) if issubclass(cls, DataLayer) \
        else set()
    where = source.path.name if source else "the default DataLayer"
    for use in uses.queries:
        if use.name not in functions:
            report.error(str(uses.file), f"query({use.name}, ...): the data layer "
                         f"({cls.__name__}, {where}) defines no function {use.name!r}"
                         + did_you_mean(use.name, functions, what="it defines"),
                         line=use.line, col=use.col, check="queries")
