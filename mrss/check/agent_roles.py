"""Every task the agent addresses to a role could be taken by some configured robot.

An environment action whose first argument is a role, `any([uav, camera])` or
`any([camera], at(Lat, Lon))` (mrss.messages.roles), asks for robots with all those
capabilities; the robots declare theirs in project.toml (`capabilities = [...]` in
`[components.<rcl>.robots.<id>]`). A capability no robot has (a typo: "did you mean"),
or a set no one robot has together, is an error at the action's file, line and column:
no robot could ever take the task, which would wait for ever.
"""

from __future__ import annotations

import difflib
from collections.abc import Mapping

from mrss.agentspeak.terms import Struct
from mrss.check.agent_clauses import Clause, SourceLines
from mrss.check.findings import Report
from mrss.messages.roles import ROLE_FUNCTOR


def check_roles(clauses: list[Clause], capabilities: Mapping[str, frozenset[str]],
                where: str, report: Report) -> None:
    """An error at each role-addressed action no robot of `capabilities` could take."""
    known = sorted({c for caps in capabilities.values() for c in caps})
    lines = SourceLines()
    for clause in clauses:
        for placed in clause.terms:
            term = placed.term
            if placed.kind != "action" or type(term) is not Struct or not term.args:
                continue
            role = term.args[0]
            if not (type(role) is Struct and role.functor == ROLE_FUNCTOR and role.args
                    and isinstance(role.args[0], tuple)):
                continue
            asked = {c.functor for c in role.args[0] if type(c) is Struct and not c.args}
            if not asked or any(asked <= caps for caps in capabilities.values()):
                continue
            missing = sorted(asked - set(known))
            if missing:
                hints = [f"{m!r}" + (f" (did you mean {close[0]!r}?)" if (
                    close := difflib.get_close_matches(m, known, n=1, cutoff=0.7)) else "")
                         for m in missing]
                problem = f"no robot has the capability {', '.join(hints)}"
            else:
                problem = f"no one robot has {', '.join(sorted(asked))} together"
            report.error(str(clause.file), f"{term.functor}/{len(term.args)} is addressed to "
                         f"{ROLE_FUNCTOR}([{', '.join(sorted(asked))}]), but {problem}: no "
                         f"robot could ever take it ({where} declares "
                         f"{', '.join(known) or 'no capabilities'})",
                         line=placed.line,
                         col=lines.column(clause.file, placed.line, term.functor, placed.col),
                         check="robots")
