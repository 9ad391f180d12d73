"""The facts one project file states about another, one rule each (run by `check_project`).

- robot ids (`agent_robots`): an atom agent.asl puts where a robot goes is a robot of
  project.toml;
- roles (`agent_roles`): a task agent.asl addresses to a role, `any([caps])`, is one
  some robot of project.toml has every capability for;
- query fit (`agent_queries`): `query(F, [Args], R)` in agent.asl fits datalayer.py's
  F: its parameters, and the shape of what it returns;
- python refs (`python_refs`): `m = import_project_module(_, "f.py")` in any .py file
  names a file of the project, `m.X` is defined by f.py, `m.X(...)` fits X's signature;
- compiles (`python_refs`): every .py file of the project folder, procedures and
  helper scripts included (the check never imports those).

Older checks state the others, each in its own module: actions -> recipes and recipes ->
skills (`recipes`), query function names (`runner._queries`), percepts <-> triggers
(`percepts`), component, layer and adapter classes named in project.toml (`runner`,
`sources`), files named in project.toml (`options`). A rule whose input is broken or
unknown is skipped (the input's own finding says why).
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass
from typing import Any

from mrss.check.agent import AgentUses
from mrss.check.agent_clauses import Clause, clauses
from mrss.check.agent_queries import check_queries
from mrss.check.agent_robots import check_robot_ids
from mrss.check.agent_roles import check_roles
from mrss.check.findings import Report
from mrss.check.python_refs import check_python_refs
from mrss.check.sources import Sources


@dataclass
class ProjectFacts:
    """What the earlier checks learned, as the cross-file rules need it."""

    sources: Sources
    uses: AgentUses | None  # None: the agent did not parse (its error says why)
    robots: set[str] | None  # None: robot ids are not the RCL's convention here
    robots_where: str  # where the robots are defined, for messages
    functions: dict[str, Callable[..., Any]] | None  # the data layer's, if known
    functions_where: str
    capabilities: dict[str, frozenset[str]] | None = None  # robot -> what it can do


Rule = Callable[[ProjectFacts, list[Clause], Report], None]


def _robot_ids(facts: ProjectFacts, agent: list[Clause], report: Report) -> None:
    if facts.uses is not None and facts.robots:
        check_robot_ids(agent, facts.robots, facts.robots_where, report)


def _roles(facts: ProjectFacts, agent: list[Clause], report: Report) -> None:
    if facts.uses is not None and facts.capabilities is not None:
        check_roles(agent, facts.capabilities, facts.robots_where, report)


def _query_fit(facts: ProjectFacts, agent: list[Clause], report: Report) -> None:
    if facts.uses is not None and facts.functions is not None:
        check_queries(agent, facts.functions, facts.functions_where, report)


def _python_refs(facts: ProjectFacts, agent: list[Clause], report: Report) -> None:
    check_python_refs(facts.sources, report)


RULES: tuple[tuple[str, Rule], ...] = (
    ("robot ids", _robot_ids),
    ("roles", _roles),
    ("query fit", _query_fit),
    ("python refs and compiles", _python_refs),
)


def check_cross_file(facts: ProjectFacts, report: Report) -> None:
    agent = list(clauses(facts.uses)) if facts.uses is not None else []
    for _, rule in RULES:
        rule(facts, agent, report)
