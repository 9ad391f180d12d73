"""Whether a program loads: every syntax and load-time error, without running it.

`load_problems` parses and compiles the program and adds its initial beliefs exactly as
`Agent` does at start (with a host that does nothing), and returns every problem found.
`mrss check` and the reasoner component both use it, so the reasoner refuses at start
(a configuration error, not restarted) what `mrss check` reports.
"""

from __future__ import annotations

from collections.abc import Sequence

from mrss.agentspeak.agent import Agent
from mrss.agentspeak.errors import AslSyntaxError, SyntaxProblem
from mrss.agentspeak.host import ConsoleHost


def load_problems(text: str, file: str, beliefs: Sequence[str] = (),
                  society: bool = False) -> list[SyntaxProblem]:
    """The problems that stop `text` (from `file`) loading as an agent; [] if it loads.
    `society`: it runs among other agents, so `.send`, `.broadcast` and `.all_names`
    are known."""
    registry = None
    if society:
        from mrss.agentspeak.society import Society

        registry = Society(out=lambda line: None).registry
    try:
        Agent(text, file=file, host=ConsoleHost(lambda line: None), beliefs=beliefs,
              out=lambda line: None, actions=registry)
    except AslSyntaxError as exc:
        return list(exc.problems)
    return []


def one_line(problems: Sequence[SyntaxProblem]) -> str:
    """The first problem as `file:line:col: message`, and how many more there are."""
    first = problems[0]
    more = f" (and {len(problems) - 1} more: run `mrss check`)" if len(problems) > 1 else ""
    return f"{first.file}:{first.line}:{first.col}: {first.message}{more}"
