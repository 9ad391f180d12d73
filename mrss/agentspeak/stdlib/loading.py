"""`.include("file.asl")` at run time: the file's beliefs, rules, plans and goals join
the agent, as the `{ include("file.asl") }` directive does when it loads."""

from __future__ import annotations

from pathlib import Path
from typing import Any

from mrss.agentspeak.errors import AslSyntaxError, SyntaxProblem
from mrss.agentspeak.registry import IAContext
from mrss.agentspeak.stdlib import STDLIB
from mrss.agentspeak.terms import deref, term_str
from mrss.textfile import NotUtf8Error, read_text


def _where(p: SyntaxProblem) -> str:
    return f"{p.file}:{p.line}:{p.col}: {p.message}"


@STDLIB.action(".include", min_args=1, max_args=2)
def include(ctx: IAContext, args: list[Any]) -> bool:
    """`.include(File)`: File is relative to the agent's own file (the working
    directory for an agent from a string)."""
    from mrss.agentspeak.compile import compile_program
    from mrss.agentspeak.parser import parse_program

    name = deref(args[0])
    if type(name) is not str:
        raise ctx.error(f"the file must be a string, not {term_str(name)}")
    if len(args) == 2:
        raise ctx.error("a namespace argument is not supported (modules of namespaces are not)")
    rt = ctx.runtime
    own = str(getattr(rt, "file", "<string>"))
    base = Path(own).parent if not own.startswith("<") else Path.cwd()
    path = base / name
    try:
        text = read_text(path)
    except NotUtf8Error as exc:
        raise ctx.error(f"cannot include {name!r}: not UTF-8 text ({exc.reason})") from None
    except OSError as exc:
        raise ctx.error(f"cannot include {name!r}: {exc.strerror or exc} ({path})") from None
    try:
        problems: list[SyntaxProblem] = []
        program = parse_program(text, str(path), collect=problems)
        compiled = compile_program(program, rt.registry, text, problems)
    except AslSyntaxError as exc:
        raise ctx.error(f"cannot include {name!r}: {_where(exc.problems[0])}") from None
    compiled.functions.rt = rt
    for clause in compiled.clauses:
        if hasattr(clause, "head"):
            h = clause.head
            rt.bb.add_rule((h.functor, len(h.args), h.neg), clause)  # type: ignore[arg-type]
        else:
            rt.bb.add(clause, front=False)
    for plan in compiled.plans:
        rt.plans.add(plan)
    for goal in compiled.goals:
        rt.post_goal(goal, None)
    return True
