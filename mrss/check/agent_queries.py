"""The agent's `query(Function, [Args], Result)` against the data layer function it calls.

Two facts a query states about datalayer.py, each checked where the query is:
- its argument list fits the function's parameters (`inspect.Signature.bind`);
- the shape it expects of the result fits what the function is declared to return (its
  return annotation): a pattern (`[A, B]`, `3`, `"s"`, `ok`, `f(X)`), or a variable
  then used as a number (arithmetic, `<` `>` `<=` `>=`) or as a list (`.member(X, R)`,
  `.nth(I, R, X)`, `.sort(R, S)`, `.max(R, M)`, `.min(R, M)`), or passed to a goal
  (`!decide(G, R)`) whose every plan takes a pattern there (`+!decide(G, ["legal"])`)
  of another shape. A return annotation that no AgentSpeak term can hold (a dict) is an
  error at any query of the function.
An unannotated function, `Any`, or a union is not checked.
"""

from __future__ import annotations

import inspect
import typing
from collections.abc import Callable, Mapping, Sequence
from enum import StrEnum
from typing import Any

from mrss.agentspeak.literals import Atom
from mrss.agentspeak.terms import Expr, PList, Slot, Struct, Term
from mrss.check.agent import QUERY
from mrss.check.agent_clauses import Clause, literals
from mrss.check.findings import Report


class Shape(StrEnum):
    """What kind of AgentSpeak term a value is (mrss.agentspeak.literals.term)."""

    NUMBER = "a number"
    STRING = "a string"
    ATOM = "an atom"
    LIST = "a list"
    STRUCT = "a structure"
    NO_TERM = "no AgentSpeak term"  # e.g. a dict: the query fails at run time


LIST_ARGUMENT = {".member": 1, ".nth": 1, ".sort": 0, ".max": 0, ".min": 0}
NUMERIC = frozenset({"<", ">", "<=", ">="})


def returned_shape(function: Callable[..., Any]) -> Shape | None:
    """The shape of what `function` is annotated to return; None when not told."""
    try:
        hint = typing.get_type_hints(function).get("return")
    except Exception:  # an annotation that does not evaluate: not ours to report
        return None
    origin = typing.get_origin(hint) or hint
    if hint is None or origin is typing.Union or hint is Any:
        return None
    if origin is bool or origin is Atom:
        return Shape.ATOM
    if isinstance(origin, type):
        if issubclass(origin, int | float):
            return Shape.NUMBER
        if issubclass(origin, str):
            return Shape.STRING
        if issubclass(origin, Mapping):
            return Shape.NO_TERM
        if issubclass(origin, list | tuple) or origin is Sequence:
            return Shape.LIST
    return None


def pattern_shape(term: Term) -> Shape | None:
    """The shape a result pattern demands; None for a variable."""
    if type(term) in (tuple, PList):
        return Shape.LIST
    if type(term) in (int, float):
        return Shape.NUMBER
    if type(term) is str:
        return Shape.STRING
    if type(term) is Struct:
        return Shape.STRUCT if term.args else Shape.ATOM
    return None


def used_shape(clause: Clause, var: str) -> tuple[Shape, int, int] | None:
    """How the clause uses variable `var` (a number or a list), and where; None if neither."""
    for placed in clause.terms:
        for term in _formulas(placed.term):
            if type(term) is Struct and term.functor in NUMERIC \
                    and any(_is_var(a, var) for a in term.args):
                return Shape.NUMBER, placed.line, placed.col
            if type(term) is Expr and any(_is_var(a, var) for a in term.args):
                return Shape.NUMBER, placed.line, placed.col
            if type(term) is Struct and term.functor in LIST_ARGUMENT \
                    and len(term.args) > LIST_ARGUMENT[term.functor] \
                    and _is_var(term.args[LIST_ARGUMENT[term.functor]], var):
                return Shape.LIST, placed.line, placed.col
    return None


Plans = dict[tuple[str, int], list[tuple[int, Struct]]]  # trigger functor/arity -> (line, lit)


def plans_by_trigger(clauses: list[Clause]) -> Plans:
    """The trigger literal of every plan, by functor and arity."""
    found: Plans = {}
    for clause in clauses:
        trigger = clause.terms[0]
        if trigger.kind == "trigger" and isinstance(trigger.term, Struct):
            key = (trigger.term.functor, len(trigger.term.args))
            found.setdefault(key, []).append((trigger.line, trigger.term))
    return found


def goal_shape(clause: Clause, var: str, plans: Plans) -> tuple[Shape, str] | None:
    """The shape every plan of a goal the clause passes `var` to takes at its position,
    and which goal; None if some plan takes anything there (a variable) or shapes differ."""
    for placed in clause.terms[1:]:
        if placed.kind not in ("achieve", "achieve_new") or not isinstance(placed.term, Struct):
            continue
        goal = placed.term
        for i, arg in enumerate(goal.args):
            if not _is_var(arg, var):
                continue
            triggers = plans.get((goal.functor, len(goal.args)), [])
            shapes = {pattern_shape(t.args[i]) for _, t in triggers if len(t.args) > i}
            if triggers and None not in shapes and len(shapes) == 1:
                shape = shapes.pop()
                assert shape is not None
                lines = ", ".join(str(line) for line, _ in triggers)
                return shape, f"passed to !{goal.functor}/{len(goal.args)}, whose plans " \
                              f"(lines {lines}) take {shape.value} as argument {i + 1}"
    return None


def _formulas(term: Term) -> typing.Iterator[Term]:
    yield term
    args = term.args if type(term) in (Struct, Expr) else ()  # type: ignore[union-attr]
    for arg in args:
        yield from _formulas(arg)


def _is_var(term: Term, name: str) -> bool:
    return type(term) is Slot and term.name == name


def check_queries(clauses: list[Clause], functions: Mapping[str, Callable[..., Any]],
                  where: str, report: Report) -> None:
    """Errors at each query whose arguments or result do not fit its function."""
    plans = plans_by_trigger(clauses)
    for clause in clauses:
        for placed in clause.terms:
            if placed.kind != "action":
                continue
            for lit in literals(placed.term):
                if lit.functor != QUERY or len(lit.args) != 3:
                    continue
                name = lit.args[0]
                function = functions.get(name.functor) if type(name) is Struct \
                    and not name.args else None
                if function is None:
                    continue  # an unknown function is the `queries` check's error
                _check_one(clause, placed.line, placed.col, name.functor,  # type: ignore[union-attr]
                           function, lit.args[1], lit.args[2], where, plans, report)


def _check_one(clause: Clause, line: int, col: int, name: str, function: Callable[..., Any],
               args: Term, result: Term, where: str, plans: Plans, report: Report) -> None:
    file = str(clause.file)
    try:
        signature = inspect.signature(function)
    except (TypeError, ValueError):
        return
    line_no = _line_of(function)
    defined = f"{name}{_plain(signature)} ({where}" + (f":{line_no}" if line_no else "") + ")"
    if type(args) is tuple:
        try:
            signature.bind(*args)
        except TypeError as exc:
            report.error(file, f"query({name}, ...): {len(args)} argument(s) do not fit "
                         f"{defined}: {exc}", line=line, col=col, check="queries")
            return
    returns = returned_shape(function)
    if returns is None:
        return
    if returns is Shape.NO_TERM:
        report.error(file, f"query({name}, ...): {defined} is declared to return "
                     f"{_hint(function)}, which no AgentSpeak term can hold (return a "
                     "number, string, Atom, bool or a list of them)", line=line, col=col,
                     check="queries")
        return
    expected = pattern_shape(result)
    use = ""
    if expected is None and type(result) is Slot:
        found = used_shape(clause, result.name)
        passed = goal_shape(clause, result.name, plans)
        if found is not None:
            expected, use_line, use_col = found
            use = f" (used so at line {use_line}" + (f":{use_col}" if use_col > 1 else "") + ")"
        elif passed is not None:
            expected, why = passed
            use = f" ({why})"
    if expected is not None and expected is not returns:
        report.error(file, f"query({name}, ...): the agent expects {expected.value}"
                     f"{use}, but {defined} returns {returns.value} ({_hint(function)})",
                     line=line, col=col, check="queries")


def _line_of(function: Callable[..., Any]) -> int:
    try:
        return inspect.getsourcelines(function)[1]
    except (OSError, TypeError):
        return 0


def _plain(signature: inspect.Signature) -> str:
    return "(" + ", ".join(p.name for p in signature.parameters.values()) + ")"


def _hint(function: Callable[..., Any]) -> str:
    hint = typing.get_type_hints(function).get("return")
    return getattr(hint, "__name__", None) or str(hint)
