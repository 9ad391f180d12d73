"""The checks of `mrss check` beyond project.toml: the project's own files, robots, links.

Each check adds to a `Findings`: errors (the project cannot run as it is), warnings and
one summary line per part. Nothing is started: agent.asl is compiled by the real
interpreter (no cycle runs), the Python files are imported from the project folder and
their classes looked up, robot tables are validated against the link factory's schema,
and no robot is connected.
"""

from __future__ import annotations

import inspect
from collections.abc import Mapping
from dataclasses import dataclass, field
from typing import Any

from mrss.agentspeak import Agent, AslSyntaxError, ConsoleHost
from mrss.api import RobotCommLayer, Skill
from mrss.config import ComponentConfig, ProjectConfig
from mrss.edge.adapters import DataLayer, ExternalAdapter
from mrss.edge.loader import import_project_module, load_project_class, project_file
from mrss.edge.predicates import is_atom_name
from mrss.errors import ConfigError
from mrss.links.factory import LINK_OPTIONS

REASONER = "mrss.actors.reasoner:ReasonerComponent"
EVENTS = "mrss.actors.events:ExternalEventsManager"
DATALAYER = "mrss.actors.datalayer:DataLayerComponent"
RCL = "mrss.actors.rcl_service:RclService"


@dataclass
class Findings:
    """What `mrss check` found: errors, warnings, and a summary line per checked part."""

    errors: list[str] = field(default_factory=list)
    warnings: list[str] = field(default_factory=list)
    summary: list[str] = field(default_factory=list)


def components_of(config: ProjectConfig, target: str) -> list[ComponentConfig]:
    return [c for c in config.components if c.enabled and c.module == target]


def key_line(config: ProjectConfig, key: str) -> str:
    """`file:line` of a dotted key of project.toml (best effort), for error messages."""
    from mrss.config import _Reader  # the config loader's own key locator

    reader = _Reader(config.file, config.file.read_text(encoding="utf-8"))
    line = reader._line_of(key)
    return f"{config.file}:{line}" if line else str(config.file)


def check_project_files(config: ProjectConfig) -> Findings:
    """Run every check on a loaded, valid project.toml."""
    found = Findings()
    check_agent(config, found)
    check_events(config, found)
    check_datalayer(config, found)
    check_rcl(config, found)
    return found


# -- agent.asl ------------------------------------------------------------------------------
def check_agent(config: ProjectConfig, found: Findings) -> None:
    reasoners = components_of(config, REASONER)
    files = {str(c.options.get("agent", "agent.asl")) for c in reasoners}
    if not files and (config.directory / "agent.asl").is_file():
        files = {"agent.asl"}
        found.warnings.append(f"{config.directory / 'agent.asl'}: no reasoner component runs it")
    for name in sorted(files):
        path = config.directory / name
        try:
            source = path.read_text(encoding="utf-8")
        except OSError as exc:
            found.errors.append(f"{path}: cannot read the agent: {exc.strerror or exc}")
            continue
        try:
            agent = Agent(source, file=str(path), host=ConsoleHost(lambda line: None),
                          name=path.stem, out=lambda line: None)
        except AslSyntaxError as exc:
            found.errors.extend(p.report() for p in exc.problems)
            continue
        snap = agent.snapshot()
        found.summary.append(f"  agent {name}: {len(source.splitlines())} lines, "
                             f"{len(snap.get('beliefs', []))} initial beliefs, parses")


# -- events.py, datalayer.py ----------------------------------------------------------------
def _section(config: ProjectConfig, name: str, comps: list[ComponentConfig]) -> dict[str, Any]:
    section = dict(config.sections.get(name, {}) or {})
    for comp in comps:
        section.update(comp.options)
    return section


def check_events(config: ProjectConfig, found: Findings) -> None:
    comps = components_of(config, EVENTS)
    section = _section(config, "events", comps)
    module = str(section.get("module", "events.py"))
    if not comps and not (config.directory / module).is_file():
        return
    try:
        cls = load_project_class(config.directory, module, ExternalAdapter,
                                 class_name=section.get("class"), key="events.module")
    except ConfigError as exc:
        found.errors.append(str(exc))
        return
    if not comps:
        found.warnings.append(f"{config.directory / module}: no events component runs it")
    found.summary.append(f"  events {module}: {cls.__name__}")


def check_datalayer(config: ProjectConfig, found: Findings) -> None:
    comps = components_of(config, DATALAYER)
    section = _section(config, "datalayer", comps)
    module = section.get("module")
    path = config.directory / str(module or "datalayer.py")
    if not path.is_file():
        if module is not None:
            found.errors.append(f"{path}: no such file (key 'datalayer.module')")
        elif comps:
            found.summary.append("  datalayer: the default DataLayer (no datalayer.py)")
        return
    try:
        cls = load_project_class(config.directory, str(module or "datalayer.py"), DataLayer,
                                 class_name=section.get("class"), key="datalayer.module")
    except ConfigError as exc:
        found.errors.append(str(exc))
        return
    functions = sorted(cls.__new__(cls).functions())
    found.summary.append(f"  datalayer {path.name}: {cls.__name__}, functions "
                         f"{', '.join(functions)}")


# -- rcl.py, skills.py, robots ----------------------------------------------------------------
def _classes(module: Any, base: type) -> list[type]:
    return [c for _, c in inspect.getmembers(module, inspect.isclass)
            if issubclass(c, base) and c.__module__ == module.__name__]


def check_rcl(config: ProjectConfig, found: Findings) -> None:
    comps = components_of(config, RCL)
    skills_file = config.directory / "skills.py"
    if skills_file.is_file():
        try:
            skills = _classes(import_project_module(config.directory, "skills.py"), Skill)
            found.summary.append(f"  skills skills.py: {', '.join(c.__name__ for c in skills)}"
                                 if skills else "  skills skills.py: (no Skill subclass)")
        except ConfigError as exc:
            found.errors.append(str(exc))
    for comp in comps:
        layer = _check_layer(config, comp, found)
        _check_robots(config, comp, layer, found)


def _check_layer(config: ProjectConfig, comp: ComponentConfig,
                 found: Findings) -> type[RobotCommLayer] | None:
    file_name, _, class_name = str(comp.options.get("layer", "") or "rcl.py").partition(":")
    key = f"components.{comp.id}.layer"
    try:
        project_file(config.directory, file_name, key=key)
        module = import_project_module(config.directory, file_name, key=key)
    except ConfigError as exc:
        found.errors.append(str(exc))
        return None
    classes = [c for c in _classes(module, RobotCommLayer)
               if not class_name or c.__name__ == class_name]
    if len(classes) != 1:
        what = f"class {class_name!r}" if class_name else "exactly one RobotCommLayer subclass"
        found.errors.append(f"{config.directory / file_name}: expected {what}, found "
                            f"{[c.__name__ for c in classes]} (key {key!r})")
        return None
    layer: type[RobotCommLayer] = classes[0]
    overridden = [m for m in ("refine_action", "check_action_status", "action_cb",
                              "connect_robot") if m in vars(layer)]
    if "refine_action" not in overridden:
        found.warnings.append(f"{config.directory / file_name}: {layer.__name__} has no "
                              "refine_action: every action will fail (no recipe)")
    found.summary.append(f"  rcl {file_name}: {layer.__name__} (defines "
                         f"{', '.join(overridden) or 'nothing'})")
    return layer


def _check_robots(config: ProjectConfig, comp: ComponentConfig,
                  layer: type[RobotCommLayer] | None, found: Findings) -> None:
    robots = comp.options.get("robots")
    key = f"components.{comp.id}.robots"
    if not isinstance(robots, Mapping) or not robots:
        found.errors.append(f"{key_line(config, key)}: key {key!r}: the RCL needs a table "
                            "of robots, e.g. [components.rcl.robots.robot1]")
        return
    own = set(getattr(layer, "robot_settings", ()) or ())
    described = []
    for robot, options in robots.items():
        rkey = f"{key}.{robot}"
        if not is_atom_name(str(robot)):
            found.errors.append(f"{key_line(config, rkey)}: key {rkey!r}: a robot id must be a "
                                "lowercase identifier (the agent names it as an atom)")
        if not isinstance(options, Mapping):
            found.errors.append(f"{key_line(config, rkey)}: key {rkey!r}: must be a table")
            continue
        kind = options.get("link")
        if kind is None:
            described.append(f"{robot}")
            continue
        for problem in link_problems(str(kind), options, own):
            found.errors.append(f"{key_line(config, f'{rkey}.{problem[0]}')}: key "
                                f"'{rkey}.{problem[0]}': {problem[1]}")
        described.append(f"{robot} ({kind})")
    found.summary.append(f"  robots: {', '.join(described)}")


def link_problems(kind: str, options: Mapping[str, Any],
                  own: set[str]) -> list[tuple[str, str]]:
    """(key, problem) for a robot's link options: kind known, no unknown key, right types.

    Required options are not enforced: the project's connect_robot may fill them in
    (a broker URL from the run folder, an address a simulator writes).
    """
    if kind not in LINK_OPTIONS:
        return [("link", f"unknown link kind {kind!r}; known: {', '.join(LINK_OPTIONS)}")]
    spec = LINK_OPTIONS[kind]
    problems = []
    for name, value in options.items():
        if name == "link" or name in own:
            continue
        if name not in spec:
            problems.append((name, f"not a {kind} link option (known: {', '.join(spec)}); "
                                   "list the layer's own keys in its robot_settings"))
            continue
        expected, _ = spec[name]
        ok = isinstance(value, expected) and not isinstance(value, bool)
        if expected is float and isinstance(value, int) and not isinstance(value, bool):
            ok = True
        if not ok:
            problems.append((name, f"must be of type {expected.__name__}, not {value!r}"))
    return problems

