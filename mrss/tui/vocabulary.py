"""What the project's agent knows of, so the percept line can warn before an operator
sends a percept the agent will never look at (a typo: `fier(a1)` for `fire(a1)`).

Read once from the agent program(s) the project's reasoner runs: the predicates a plan's
trigger adds or removes as a belief (`+fire(A)`, `-fire(A)`), and every predicate named
anywhere else (contexts, bodies, rules, initial beliefs: a percept may matter in a
context with no plan of its own). A percept is `handled` when a trigger reacts to it,
`used` when only a context or rule reads it, and `unknown` when the program names it
nowhere; then the warning names the closest predicates a plan reacts to. Warnings never stop a
percept: the operator may know better. Nothing here knows Textual.
"""

from __future__ import annotations

import difflib
from collections.abc import Iterable, Iterator
from dataclasses import dataclass, field
from enum import StrEnum
from pathlib import Path
from typing import Any

from mrss.agentspeak.agent import read_program
from mrss.agentspeak.errors import AslSyntaxError
from mrss.agentspeak.parser import parse_literal, parse_program
from mrss.agentspeak.syntax import BeliefSrc, GoalSrc, IfItem, LoopItem, PlanSrc, RuleSrc
from mrss.agentspeak.terms import ADD_BEL, DEL_BEL, Expr, PList, Struct, Trigger, VarAnnot
from mrss.config.kinds import ComponentKind

Predicate = tuple[str, int]  # functor, arity


class Reach(StrEnum):
    """How far the agent's program reaches a percept."""

    HANDLED = "handled"  # a plan's trigger reacts to it being added (or removed)
    USED = "used"  # named (a context, rule, body, another trigger); no plan reacts to it
    UNKNOWN = "unknown"  # named nowhere in the program


@dataclass
class Vocabulary:
    """The predicates of the agent's program(s): reacted to on add, on remove, named."""

    on_add: set[Predicate] = field(default_factory=set)
    on_remove: set[Predicate] = field(default_factory=set)
    named: set[Predicate] = field(default_factory=set)

    @classmethod
    def of_files(cls, paths: Iterable[Path]) -> Vocabulary:
        """Every program that reads and parses (the reasoner reports the others)."""
        vocabulary = cls()
        for path in paths:
            try:
                program = parse_program(read_program(path), str(path), collect=[])
            except (OSError, UnicodeDecodeError, AslSyntaxError, RecursionError):
                continue
            for statement in program.statements:
                vocabulary._add(statement)
        return vocabulary

    @property
    def empty(self) -> bool:
        return not self.named

    def _add(self, statement: Any) -> None:
        if isinstance(statement, PlanSrc):
            lit = statement.trigger
            if statement.op in (ADD_BEL, DEL_BEL) and isinstance(lit, Struct):
                target = self.on_add if statement.op == ADD_BEL else self.on_remove
                target.add((lit.functor, len(lit.args)))
            self.named.update(_predicates(statement.trigger))
            if statement.context is not None:
                self.named.update(_predicates(statement.context))
            self.named.update(_in_body(statement.body))
        elif isinstance(statement, RuleSrc):
            self.named.update(_predicates(statement.head))
            self.named.update(_predicates(statement.body))
        elif isinstance(statement, (BeliefSrc, GoalSrc)):
            self.named.update(_predicates(statement.lit))

    def reach(self, literal: str, *, remove: bool = False) -> Reach:
        """How the program reaches this percept (added, or removed with `remove`)."""
        predicate = _predicate(literal)
        if predicate is None:
            return Reach.UNKNOWN
        if predicate in (self.on_remove if remove else self.on_add):
            return Reach.HANDLED
        return Reach.USED if predicate in self.named else Reach.UNKNOWN

    def warning(self, literal: str, *, remove: bool = False) -> str:
        """"" when a plan reacts to the percept; else what the operator should know."""
        if self.empty:
            return ""
        predicate = _predicate(literal)
        reach = self.reach(literal, remove=remove)
        if predicate is None or reach is Reach.HANDLED:
            return ""
        name = f"{predicate[0]}/{predicate[1]}"
        sign = "-" if remove else "+"
        if reach is Reach.USED:
            return f"no plan reacts to {sign}{name}; the agent only has it as a belief"
        # the percepts it does react to: what an operator most likely meant
        known = sorted({f"{f}/{n}" for f, n in self.on_add | self.on_remove})
        close = difflib.get_close_matches(name, known, n=3, cutoff=0.6)
        hint = f" (did you mean {' or '.join(close)}?)" if close else ""
        return f"the agent never names {name}: no plan handles it{hint}"


def _predicate(literal: str) -> Predicate | None:
    try:
        parsed = parse_literal(literal)
    except (AslSyntaxError, AssertionError, ValueError, RecursionError):
        return None
    return parsed.functor, len(parsed.args)


def _in_body(body: Iterable[Any]) -> Iterator[Predicate]:
    for item in body:
        if isinstance(item, IfItem):
            for cond, branch in item.branches:
                yield from _predicates(cond)
                yield from _in_body(branch)
            yield from _in_body(item.else_body or ())
        elif isinstance(item, LoopItem):
            yield from _predicates(item.cond)
            yield from _in_body(item.body)
        else:
            yield from _predicates(getattr(item, "term", None))


def _predicates(term: Any) -> Iterator[Predicate]:
    """Every compound or atom named inside a term (operators included: harmless)."""
    stack = [term]
    while stack:
        t = stack.pop()
        if isinstance(t, Struct):
            yield t.functor, len(t.args)
            stack.extend(t.args)
            stack.extend(t.annots)
        elif isinstance(t, Trigger):
            stack.append(t.lit)
        elif isinstance(t, (Expr, VarAnnot)):
            stack.extend(t.args if isinstance(t, Expr) else (t.var, *t.annots))
        elif isinstance(t, PList):
            stack.extend(t.items)
            stack.append(t.tail)




def project_agent_files(components: Iterable[Any], project_dir: Path) -> list[Path]:
    """The agent programs the project's enabled reasoners run (`agent`, or `agents`)."""
    from mrss.actors.reasoner.agents import agent_specs
    from mrss.errors import ConfigError

    files: list[Path] = []
    for comp in components:
        if not comp.enabled or comp.kind is not ComponentKind.REASONER:
            continue
        try:
            specs = agent_specs(dict(comp.options), project_dir)
        except ConfigError:
            continue  # `mrss check` names it; the dashboard just warns less
        names = [s.file for s in specs] if specs else [str(comp.options.get("agent",
                                                                          "agent.asl"))]
        files += [project_dir / name for name in names]
    return sorted(set(files))
