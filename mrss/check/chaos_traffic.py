"""`chaos.py`: the operator traffic of `mrss chaos`, as `mrss check` sees it.

The file must import and its steps read (`mrss.chaos.traffic`: the first `STEPS_READ`
of seed 0 are drawn). An operator that sends goals must say which of the agent's
beliefs hold one (`PENDING_BELIEFS`): without them nothing does, and a goal the agent
still pursues when a campaign ends counts as dropped (the goal-handled invariant). A
pending belief agent.asl never names is probably misspelt. Every finding is a warning:
the file matters to a campaign only, never to `mrss supervise`.
"""

from __future__ import annotations

import re
from itertools import islice
from pathlib import Path

from mrss.agentspeak.agent import read_program
from mrss.chaos.traffic import CHAOS_FILE, Intent, load_traffic
from mrss.check.findings import Report
from mrss.config.operator import SECTION, GoalState, read_operator
from mrss.config.project import ProjectConfig
from mrss.errors import ConfigError

STEPS_READ = 200
PENDING = "PENDING_BELIEFS"
#: the `[operator.goals]` states in which a goal is still pursued, offered as the example
PURSUED = (GoalState.QUEUED, GoalState.RUNNING, GoalState.SUSPENDED)


def check_chaos_traffic(config: ProjectConfig, report: Report, *,
                        agent_files: list[Path]) -> None:
    """Findings for the project's chaos.py; nothing when it has none."""
    path = config.directory / CHAOS_FILE
    if not path.is_file():
        return
    file = str(path)
    try:
        traffic = load_traffic(config.directory)
        steps = list(islice(traffic.steps(0, 20.0), STEPS_READ))
    except ConfigError as exc:
        report.warning(file, f"mrss chaos cannot use it: {exc.reason}", check="chaos",
                       key=exc.key)
        return
    except Exception as exc:  # the project's own generator failed: say how
        report.warning(file, f"mrss chaos cannot use it: operator_traffic raised {exc!r}",
                       check="chaos")
        return
    goals = [s.goal for s in steps if s.intent is Intent.GOAL]
    line = _line(path, PENDING)
    if goals and not traffic.pending_beliefs:
        report.warning(file, f"the operator sends goals ({goals[0]}, ...) but {PENDING} "
                       "names no belief that holds one: a goal the agent still pursues "
                       "when a campaign ends counts as dropped; declare them, e.g. "
                       f"{PENDING} = {_example(config)}", line=line, check="chaos",
                       key=PENDING)
    agent_text = "\n".join(_program(a) for a in agent_files)
    if agent_text:
        for functor in traffic.pending_beliefs:
            if not re.search(rf"\b{re.escape(functor)}\(", agent_text):
                report.warning(file, f"{PENDING}: agent.asl never names {functor}(...)",
                               line=line, check="chaos", key=PENDING)
    intents = sorted({s.intent.value for s in steps})
    report.summary.append(f"  chaos.py: operator steps {', '.join(intents) or 'none'}; "
                          f"pending beliefs {', '.join(traffic.pending_beliefs) or 'none'}")


def _example(config: ProjectConfig) -> str:
    """The functors of the project's `[operator.goals]` pursued states, if it has them."""
    try:
        goals = read_operator(config.sections.get(SECTION)).goals
    except ConfigError:
        goals = {}
    functors = [goals[s].functor for s in PURSUED if s in goals]
    return repr(functors or ["queued", "task"])


def _program(path: Path) -> str:
    try:
        return read_program(path)
    except OSError:
        return ""


def _line(path: Path, name: str) -> int:
    """The line that assigns `name` in `path` (0 when none does)."""
    for number, text in enumerate(path.read_text(encoding="utf-8").splitlines(), 1):
        if re.match(rf"{name}\s*[:=]", text):
            return number
    return 0
