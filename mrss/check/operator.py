"""`[operator]`: the operator commands a project declares and its goal patterns.

The table must read (`mrss.config.operator.read_operator`: known commands, topics
without wildcards, goal patterns that parse and name Goal); commands need an events
manager to turn them into percepts, and a topic outside `[events] topic_prefix` is
probably not one the project's adapter reads; a goal pattern whose predicate agent.asl
never writes is probably misspelt.
"""

from __future__ import annotations

import re
from pathlib import Path

from mrss.agentspeak.agent import read_program
from mrss.check.findings import Report
from mrss.check.toml_lines import key_line, read_table
from mrss.config.operator import SECTION, OperatorConfig, read_operator
from mrss.config.project import ProjectConfig


def check_operator(config: ProjectConfig, report: Report, *, events_running: bool,
                   agent_files: list[Path]) -> OperatorConfig | None:
    """Findings for `[operator]`; the table read, or None when it is absent or wrong."""
    operator = read_table(config, report, SECTION, read_operator, title="[operator]")
    if operator is None:
        return None
    file = str(config.file)
    if operator.topics and not events_running:
        report.error(file, "[operator] declares commands, but no events manager runs "
                     "(kind = \"events\") to make them percepts",
                     line=key_line(config, SECTION), check="operator", key=SECTION)
    events = config.sections.get("events", {})
    prefix = events.get("topic_prefix") if isinstance(events, dict) else None
    if isinstance(prefix, str) and prefix:
        for command, topic in operator.topics.items():
            if not topic.startswith(prefix.rstrip("/") + "/"):
                key = f"{SECTION}.{command.value}"
                report.warning(file, f"[operator] {command.value} = {topic!r} is outside "
                               f"[events] topic_prefix {prefix!r}: does the adapter read it?",
                               line=key_line(config, key), check="operator", key=key)
    text = "\n".join(_read(path) for path in agent_files)
    if text:
        for state, pattern in operator.goals.items():
            if not re.search(rf"\b{re.escape(pattern.functor)}\(", text):
                key = f"{SECTION}.goals.{state.value}"
                report.warning(file, f"[operator.goals] {state.value}: agent.asl never "
                               f"names {pattern.functor}/{pattern.arity}",
                               line=key_line(config, key), check="operator", key=key)
    commands = ", ".join(c.value for c in operator.topics) or "none"
    states = ", ".join(s.value for s in operator.goals) or "none"
    report.summary.append(f"  operator: commands {commands}; goal states {states}")
    return operator


def _read(path: Path) -> str:
    try:
        return read_program(path)
    except OSError:
        return ""
