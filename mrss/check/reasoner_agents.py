"""The reasoner's `agents` option (several agents, like a `.mas2j`): every entry a table
with `file` (a program in the project), `name` (an atom, unique) and `beliefs`; an
unknown key is an error with "did you mean"; each finding at the line and column of the
entry (or its key) in project.toml."""

from __future__ import annotations

import re
from pathlib import Path

from mrss.actors.reasoner.agents import AGENT_KEYS, AgentProblem, AgentSpec, parse_agents
from mrss.check.findings import Report, did_you_mean
from mrss.check.toml_lines import key_line
from mrss.config.project import ComponentConfig, ProjectConfig
from mrss.textfile import NotUtf8Error, read_text


def _position(text: str, start_line: int, problem: AgentProblem) -> tuple[int, int]:
    """Line and column of entry `problem.index` (its `{`, or its key) of the array that
    starts at `start_line`; (start_line, 0) when it cannot be found."""
    lines = text.splitlines(keepends=True)
    if not 0 < start_line <= len(lines) or problem.index < 0:
        return start_line, 0
    offset = sum(len(line) for line in lines[:start_line - 1])
    pos = offset
    for _ in range(problem.index + 1):
        pos = text.find("{", pos)
        if pos < 0:
            return start_line, 0
        pos += 1
    pos -= 1
    end = text.find("}", pos)
    if problem.key is not None:
        m = re.compile(rf"\b{re.escape(problem.key)}\s*=").search(text, pos, end if end > 0
                                                                   else len(text))
        if m is not None:
            pos = m.start()
    line = text.count("\n", 0, pos) + 1
    col = pos - (text.rfind("\n", 0, pos) + 1) + 1
    return line, col


def check_agents(config: ProjectConfig, comp: ComponentConfig,
                 report: Report) -> list[AgentSpec] | None:
    """Findings for the `agents` option of reasoner `comp`; its agents (those without
    problems), or None when it has no `agents` option."""
    value = comp.options.get("agents")
    if value is None:
        return None
    key = f"components.{comp.id}.agents"
    line = key_line(config, key)
    if "agent" in comp.options or "beliefs" in comp.options:
        report.error(str(config.file), "give the agents either with agent (and beliefs) or "
                     "with agents, not both", line=line, check="options", key=key)
    specs, problems = parse_agents(value, Path(config.directory))
    try:
        text = read_text(config.file)
    except (OSError, NotUtf8Error):
        text = ""
    for p in problems:
        at_line, col = _position(text, line, p)
        message = p.message
        if p.message == "unknown key of an agent" and p.key is not None:
            message = f"unknown key {p.key!r} of an agent" + did_you_mean(
                p.key, AGENT_KEYS, what="an agent has")
        where = f"agent {p.index + 1} of agents: " if p.index >= 0 else "agents: "
        report.error(str(config.file), where + message, line=at_line, col=col,
                     check="options", key=key)
    return specs
