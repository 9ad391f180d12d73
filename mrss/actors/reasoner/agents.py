"""Several agents in one reasoner component: the `agents` option, like Jason's `.mas2j`.

    [components.reasoner]
    kind = "reasoner"
    agents = [
      { name = "leader", file = "leader.asl" },
      { name = "scout", file = "scout.asl", beliefs = ["zone(z1)"] },
    ]

Each entry is an agent: `file` (its program, in the project folder), `name` (an atom,
default the file's stem) and `beliefs` (extra initial beliefs). The agents run in one
`mrss.agentspeak.society.Society` (round-robin cycles; `.send`, `.broadcast`,
`.all_names`, `.my_name` between them); every agent perceives every percept (as
Jason's default environment gives each agent all percepts); their environment actions
share the component's one `ReasonerHost` (latches, lease, reconciliation, adoption),
each completion routed back to the agent that acted (`ActionRouter`).
"""

from __future__ import annotations

import re
import threading
from collections.abc import Hashable, Mapping
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from mrss.actors.reasoner.give_up import is_give_up
from mrss.actors.reasoner.host import ReasonerHost
from mrss.actors.reasoner.questions import is_question
from mrss.agentspeak.agent import Agent
from mrss.agentspeak.terms import Struct
from mrss.errors import ConfigError

AGENT_KEYS = ("name", "file", "beliefs")
_ATOM = re.compile(r"^[a-z][A-Za-z0-9_]*$")


@dataclass(frozen=True)
class AgentSpec:
    """One entry of the `agents` option."""

    name: str
    file: str
    beliefs: list[str] = field(default_factory=list)


@dataclass(frozen=True)
class AgentProblem:
    """What is wrong with entry `index` of `agents` (key `key`, or the entry itself)."""

    index: int
    key: str | None
    message: str


def parse_agents(value: Any, project_dir: Path) -> tuple[list[AgentSpec], list[AgentProblem]]:
    """The agents of an `agents` option, and every problem found (then the specs may be
    incomplete)."""
    problems: list[AgentProblem] = []
    if not isinstance(value, list) or not value:
        return [], [AgentProblem(-1, None, "expected a non-empty list of agent tables "
                                           "({ name = \"a\", file = \"a.asl\" }, ...)")]
    specs: list[AgentSpec] = []
    names: set[str] = set()
    for i, entry in enumerate(value):
        if not isinstance(entry, Mapping):
            problems.append(AgentProblem(i, None, f"expected a table such as {{ file = "
                                                  f"\"a.asl\" }}, not {entry!r}"))
            continue
        unknown = [str(k) for k in entry if k not in AGENT_KEYS]
        for key in unknown:
            problems.append(AgentProblem(i, key, "unknown key of an agent"))
        if unknown:  # a misspelt key: what is missing follows from it
            continue
        bad = False
        file = entry.get("file")
        if not isinstance(file, str) or not file:
            problems.append(AgentProblem(i, "file" if "file" in entry else None,
                                         "each agent needs file = \"program.asl\"" if file is None
                                         else f"expected a file name, not {file!r}"))
            continue
        if not (project_dir / file).is_file():
            problems.append(AgentProblem(i, "file", f"no file {file!r} in the project folder"))
            bad = True
        name = entry.get("name", Path(file).stem)
        if not isinstance(name, str) or not _ATOM.match(name):
            problems.append(AgentProblem(i, "name" if "name" in entry else "file",
                                         f"the agent's name {name!r} must be an atom (a "
                                         "lower-case letter, then letters, digits or _)"))
            bad = True
        elif name in names:
            problems.append(AgentProblem(i, "name" if "name" in entry else "file",
                                         f"two agents are named {name!r}"))
            bad = True
        beliefs = entry.get("beliefs", [])
        if not isinstance(beliefs, list) or not all(isinstance(b, str) for b in beliefs):
            problems.append(AgentProblem(i, "beliefs", "expected a list of belief strings"))
            bad = True
        if not bad:
            names.add(name)
            specs.append(AgentSpec(name, file, list(beliefs)))
    return specs, problems


class ActionRouter:
    """The `agent` of a shared `ReasonerHost`: each completion goes to the agent whose
    action it was (a completion may come before `bind`, from a query thread: it waits)."""

    def __init__(self) -> None:
        self._lock = threading.Lock()
        self._owner: dict[Hashable, Agent] = {}
        self._early: dict[Hashable, tuple[Any, ...]] = {}

    def bind(self, handle: Hashable, agent: Agent) -> None:
        with self._lock:
            early = self._early.pop(handle, None)
            if early is None:
                self._owner[handle] = agent
                return
        agent.complete_action(handle, early[0], early[1], result=early[2], error=early[3])

    def forget(self, handle: Hashable) -> None:
        with self._lock:
            self._owner.pop(handle, None)
            self._early.pop(handle, None)

    def complete_action(self, handle: Hashable, success: bool, reason: str | None = None,
                        result: str | Struct | None = None, error: str | None = None) -> None:
        with self._lock:
            agent = self._owner.pop(handle, None)
            if agent is None:
                self._early[handle] = (success, reason, result, error)
                return
        agent.complete_action(handle, success, reason, result=result, error=error)


class AgentHost:
    """One agent's view of the shared host: its actions are bound to it."""

    open_actions = ReasonerHost.open_actions

    def __init__(self, shared: ReasonerHost, router: ActionRouter) -> None:
        self.shared = shared
        self.router = router
        self.agent: Agent | None = None

    def execute(self, action: Struct, intention_id: int) -> Hashable:
        assert self.agent is not None
        if is_give_up(action):
            handle = self.shared.give_up(action, self.agent.name)
        elif is_question(action):
            handle = self.shared.ask(action, self.agent.name)
        else:
            handle = self.shared.execute(action, intention_id)
        self.router.bind(handle, self.agent)
        return handle

    def cancel(self, handle: Hashable) -> None:
        self.router.forget(handle)
        self.shared.cancel(handle)


def agent_specs(opts: dict[str, Any], project_dir: Path) -> list[AgentSpec] | None:
    """The `agents` option's agents (None without it); ConfigError naming the first
    problem (`mrss check` lists them all, with line and column)."""
    if opts.get("agents") is None:
        return None
    if "agent" in opts or "beliefs" in opts:
        raise ConfigError("give the agents either with agent (and beliefs) or with agents, "
                          "not both", key="agents")
    specs, problems = parse_agents(opts["agents"], project_dir)
    if problems:
        p = problems[0]
        where = "" if p.index < 0 else f"agent {p.index + 1}" + (f", {p.key}" if p.key else "")
        raise ConfigError(f"{where}: {p.message}" if where else p.message, key="agents")
    return specs
