"""What agent.asl asks of the rest of the project, read from its parsed program.

- environment actions: every body formula `name(Args)` that is neither an internal action
  (`.name`) nor one the reasoner handles itself (`query/3`, `rcl_goal_management`,
  `give_up/3`), by name and arity, each with its first line and column;
- queries: the function of every `query(Function, Args, Result)` whose Function is an atom;
- triggers: the belief events (`+b`/`-b`) the agent's plans react to, by name and arity.
Syntax errors are findings at their line and column, with a caret (the interpreter's own
report); a program that does not parse gives no uses, so no later check guesses at it.
"""

from __future__ import annotations

from collections.abc import Iterator, Sequence
from dataclasses import dataclass, field
from pathlib import Path

from mrss.actors.reasoner.give_up import is_give_up
from mrss.agentspeak import AslSyntaxError
from mrss.agentspeak.agent import read_program
from mrss.agentspeak.loadcheck import load_problems
from mrss.agentspeak.parser import parse_program
from mrss.agentspeak.syntax import BodyItem, BodyNode, IfItem, LoopItem, PlanSrc, Program
from mrss.agentspeak.terms import Struct
from mrss.check.findings import Report

QUERY = "query"
GOAL_MANAGEMENT = "rcl_goal_management"
ADD_BELIEF, DEL_BELIEF = 0, 1  # plan trigger operators `+b`, `-b` (agentspeak.terms.OP_TEXT)


@dataclass(frozen=True)
class Use:
    """One place the agent names something: `name/arity` at file:line:col."""

    name: str
    arity: int
    line: int
    col: int
    from_percept: bool = False  # a trigger annotated [source(percept)]


@dataclass
class AgentUses:
    """Everything the agent needs from the project, first use of each first."""

    file: Path
    actions: list[Use] = field(default_factory=list)
    queries: list[Use] = field(default_factory=list)
    triggers: list[Use] = field(default_factory=list)
    beliefs: int = 0
    lines: int = 0
    programs: list[Program] = field(default_factory=list)  # parsed, for the cross-file rules

    def merged(self, other: AgentUses) -> AgentUses:
        """What two agents of the project use together (this one's file named)."""
        return AgentUses(self.file, self.actions + other.actions,
                         self.queries + other.queries, self.triggers + other.triggers,
                         self.beliefs + other.beliefs, self.lines + other.lines,
                         self.programs + other.programs)


def read_agent(path: Path, report: Report, beliefs: Sequence[str] = (),
               society: bool = False) -> AgentUses | None:
    """Parse agent.asl; syntax errors go to the report and give None. `society`: the
    program runs among other agents (the reasoner's `agents`)."""
    try:
        text = read_program(path)
    except OSError as exc:
        report.error(str(path), f"cannot read the agent: {exc.strerror or exc}", check="agent")
        return None
    except AslSyntaxError as exc:  # not UTF-8
        text, problems = "", list(exc.problems)
    else:
        problems = []
    program = parse_program(text, file=str(path), collect=problems)
    if not problems:  # the whole load: what parses may still not compile
        problems = load_problems(text, str(path), beliefs, society=society)
    for p in problems:
        caret = " " * (max(p.col, 1) - 1) + "^"
        report.error(p.file, p.message, line=p.line, col=p.col, check="agent",
                     detail=f"    {p.source_line}\n    {caret}")
    if problems:
        return None
    uses = AgentUses(path, lines=len(text.splitlines()), programs=[program])
    for statement in program.statements:
        if isinstance(statement, PlanSrc):
            if statement.op in (ADD_BELIEF, DEL_BELIEF):
                t = statement.trigger
                uses.triggers.append(Use(t.functor, len(t.args), statement.line, 1,
                                         _from_percept(t)))
            for item in _items(statement.body):
                _add_use(uses, item)
        elif type(statement).__name__ == "BeliefSrc":
            uses.beliefs += 1
    return uses


def _items(body: list[BodyNode]) -> Iterator[BodyItem]:
    for node in body:
        if isinstance(node, BodyItem):
            yield node
        elif isinstance(node, IfItem):
            for _, branch in node.branches:
                yield from _items(branch)
            if node.else_body:
                yield from _items(node.else_body)
        elif isinstance(node, LoopItem):
            yield from _items(node.body)


def _add_use(uses: AgentUses, item: BodyItem) -> None:
    term = item.term
    if item.kind != "action" or type(term) is not Struct:
        return
    if term.functor == QUERY and len(term.args) == 3:
        function = term.args[0]
        if type(function) is Struct and not function.args:
            uses.queries.append(Use(function.functor, 0, item.line, item.col))
        elif isinstance(function, str):
            uses.queries.append(Use(function, 0, item.line, item.col))
        return
    if term.functor == GOAL_MANAGEMENT or is_give_up(term):
        return
    uses.actions.append(Use(term.functor, len(term.args), item.line, item.col))


def _from_percept(trigger: Struct) -> bool:
    for annot in trigger.annots or ():
        if type(annot) is Struct and annot.functor == "source" and annot.args \
                and type(annot.args[0]) is Struct and annot.args[0].functor == "percept":
            return True
    return False
