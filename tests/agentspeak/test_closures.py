"""The generated functions of `closures` compute exactly what the general code does:
each body template resolves to the same term (or the same error), each compiled
context gives the same answer with the same bindings (or the same error)."""

from __future__ import annotations

import itertools
from typing import Any

import pytest

from mrss.agentspeak.agent import Agent
from mrss.agentspeak.errors import AslRuntimeError
from mrss.agentspeak.terms import Struct, Var, term_str
from mrss.agentspeak.unify import resolve

PROGRAM = """
b(1). b(2). b(a).
+!t(A, B, C) : A < B <- !g(A + B * 2, [A, B | C], f(A)[x]); +b(A - C, "s", -A);
    -b(A div B); act(A / B, C, A mod B, A ** B).
+!t(A, B, C) : A mod 2 == 0 & B \\== a <- !g(f(A, g(B)), [C, 1.5], "t").
+!t(A, B, C) : not b(A) & A >= 1 <- +c(A, B, C).
+!t(A, B, C) : A = f(B) & A == f(1) <- -c(A).
+!t(A, B, C) : b(X) & X > A <- !g(X).
+!t(A, B, C) : X = A + 1 & b(X) <- !g(X + C).
+!t(A, B, C) : A <= B & B >= C & A > 0 & A \\== C & true <- !g(A).
+!t(A, B, C) : A < B | B < C <- !g(A).
+!t(A, B, C) : b(X) & Y = X & Y > A & b(Z) & Z \\== X & not (Z == C) <- !g(Y, Z).
"""


def _values() -> list[Any]:
    bound = Var("V")
    bound.ref = 3
    return [None, 0, 1, 2, 2.5, -3, "s", Struct("a"), Struct("f", (1,)), (1, 2), bound]


def _frames(nslots: int) -> list[list[Any]]:
    vals = _values()
    frames = []
    for combo in itertools.product(vals, repeat=min(nslots, 3)):
        frames.append(list(combo) + [None] * (nslots - min(nslots, 3)))
    return frames


def _outcome(fn: Any) -> tuple[str, Any]:
    try:
        return "ok", fn()
    except AslRuntimeError as exc:
        return "error", exc.message
    except ZeroDivisionError as exc:  # pragma: no cover - would be a bug either way
        return "crash", str(exc)


def _show(frame: list[Any]) -> list[str]:
    return ["-" if v is None else term_str(v) for v in frame]


@pytest.fixture(scope="module")
def agent() -> Agent:
    return Agent(PROGRAM, name="closures", out=lambda _: None)


def test_every_simple_context_is_compiled(agent: Agent) -> None:
    tests = [p.test is not None for p in agent.plans.plans]
    # `A < B | B < C` is one general query: it keeps its generator
    assert tests == [True, True, True, True, True, True, True, False, True]


def test_compiled_templates_resolve_as_the_general_resolve(agent: Agent) -> None:
    checked = 0
    for plan in agent.plans.plans:
        for ins in plan.code:
            res = getattr(ins, "res", None)
            if res is None:
                continue
            for frame in _frames(plan.nslots):
                f1, f2 = list(frame), list(frame)
                got = _outcome(lambda: term_str(res(f1)))  # noqa: B023
                want = _outcome(lambda: term_str(resolve(ins.lit, f2)))  # noqa: B023
                assert got == want, (ins.text(), _show(frame))
                assert _show(f1) == _show(f2), (ins.text(), _show(frame))
                checked += 1
    assert checked > 1000


def test_compiled_contexts_answer_as_the_general_query(agent: Agent) -> None:
    checked = 0
    for plan in agent.plans.plans:
        if plan.test is None:
            continue
        for frame in _frames(plan.nslots):
            f1, f2 = list(frame), list(frame)

            def general(f: list[Any] = f2, p: Any = plan) -> bool:
                for _ in p.context.solve(agent, f):
                    return True
                return False

            got = _outcome(lambda: plan.test(agent, f1))  # type: ignore[misc]  # noqa: B023
            want = _outcome(general)
            agent.trail.clear()
            assert got == want, (plan.line, _show(frame))
            if got == ("ok", True):
                assert _show(f1) == _show(f2), (plan.line, _show(frame))
            checked += 1
    assert checked > 1000


def test_a_failed_compiled_condition_leaves_no_binding() -> None:
    lines: list[str] = []
    program = """
!go.
+!go <- if (X = 3 & X > 5) { .print(yes) } else { .print(no) };
    if (X = 4) { .print(X) };
    +c(0); while (c(J) & K = J & K < 3) { .print(K); -+c(K + 1) }; ?c(N); .print(done(N)).
"""
    Agent(program, name="cond", out=lines.append).run_until_idle()
    assert lines == ["no", "4", "0", "1", "2", "done(3)"]


def test_a_context_of_many_belief_queries_still_loads_and_answers() -> None:
    lines: list[str] = []
    queries = " & ".join(f"b(X{i})" for i in range(30))
    program = f"b(1).\n!go.\n+!go : {queries} & X29 > 0 <- .print(ok(X0)).\n"
    agent = Agent(program, name="many", out=lines.append)
    agent.run_until_idle()
    assert lines == ["ok(1)"]
    assert agent.plans.plans[0].test is None  # too many nested loops: the general query


def test_deeply_nested_templates_still_load_and_resolve() -> None:
    lines: list[str] = []
    for depth in (10, 30, 63, 200):
        nested = "f(" * depth + "X" + ")" * depth
        arith = "X" + " + 1" * depth
        program = (f"!go(1).\n+!go(X) <- +b({nested}); !show({arith}); ?b(B); .print(B).\n"
                   "+!show(V) <- .print(V).\n")
        lines.clear()
        Agent(program, name="deep", out=lines.append).run_until_idle()
        assert lines == [str(1 + depth), "f(" * depth + "1" + ")" * depth]


def test_mod_and_div_by_a_constant_keep_javas_sign_rule() -> None:
    lines: list[str] = []
    program = """
!go.
+!go <- for (.member(X, [7, -7, 6, -6, 0, 7.9, -7.9])) { !show(X mod 3, X div 3, X mod 1) }.
+!show(M, D, One) <- .print(M, " ", D, " ", One).
"""
    Agent(program, name="mod", out=lines.append).run_until_idle()
    # Java: the remainder has the sign of the dividend; the quotient truncates
    assert lines == ["1 2 0", "-1 -2 0", "0 2 0", "0 -2 0", "0 0 0", "1 2 0", "-1 -2 0"]
