"""The generated plan selection of `selection` picks exactly what the general loop
picks: the same plan with the same frame (or the same "relevant but none applicable"
/ "none relevant"), the same warnings for contexts that raise, no binding left behind;
a plan added or removed at run time is seen by the next event."""

from __future__ import annotations

import itertools
import logging
from typing import Any

import pytest

from mrss.agentspeak.agent import Agent
from mrss.agentspeak.selection import select_general, selector
from mrss.agentspeak.terms import ADD_ACH, ADD_BEL, Struct, Var, term_str

PROGRAM = """
b(1). b(2). b(a).
+!t(0, 0, 0) <- true.
+!t(A, B, C) : A < B <- true.
+!t(A, B, C) : A mod 2 == 0 & B \\== a & C div 3 > 0 <- true.
+!t(A, B, C) : not b(A) & A >= 1 <- true.
+!t(A, B, C) : A = f(B) & A == f(1) <- true.
+!t(A, B, C) : b(X) & X > A & X / C > 0 <- true.
+!t(A, A, C) : b(A) <- true.
+!t(A, B, C)[x] <- true.
+!t(A, B, C) : A < B | B < C <- true.
+!t(A, B, C) : b(X) & Y = X & Y > A & b(Z) & Z \\== X & not (Z == C) <- true.
+!t(f(A), B, C) : A ** B > 100 <- true.
+b(X) : X > 1 <- true.
+b(X) : X = a <- true.
"""


def _values() -> list[Any]:
    bound = Var("V")
    bound.ref = 3
    return [0, 1, 2, 2.5, -3, -7, 7, "s", Struct("a"), Struct("f", (1,)), Struct("f", (5,)),
            (1, 2), bound, Var("U")]


def _show(found: Any) -> Any:
    if type(found) is not tuple:
        return found
    plan, frame = found
    return plan.line, ["-" if v is None else term_str(v) for v in frame]


@pytest.fixture(scope="module")
def agent() -> Agent:
    return Agent(PROGRAM, name="select", out=lambda _: None)


@pytest.mark.parametrize("key", [(ADD_ACH, "t", 3, False), (ADD_BEL, "b", 1, False)])
def test_the_generated_selection_picks_what_the_general_loop_picks(
        agent: Agent, key: tuple[int, str, int, bool],
        caplog: pytest.LogCaptureFixture) -> None:
    plans = agent.plans.index[key]
    generated, general = selector(plans, key[2]), select_general(plans)
    assert generated.__code__.co_filename.startswith("<asl select ")  # not the fallback
    checked = 0
    annots: list[tuple[Any, ...]] = [(), (Struct("x"),)]
    n = len(_values())
    for pick in itertools.product(range(n), repeat=key[2]):
        for ann in annots:
            # each run its own values: a chosen plan keeps its bindings of variables
            lit, lit2 = (Struct(key[1], tuple(vals[i] for i in pick), ann)
                         for vals in (_values(), _values()))
            caplog.clear()
            with caplog.at_level(logging.WARNING, logger="mrss.agentspeak"):
                want = _show(general(agent, lit))
                warned = [r.getMessage() for r in caplog.records]
                assert not agent.trail
                caplog.clear()
                got = _show(generated(agent, lit2))
                assert not agent.trail
            assert got == want, term_str(lit)
            assert [r.getMessage() for r in caplog.records] == warned, term_str(lit)
            checked += 1
    assert checked == len(annots) * n ** key[2]


def test_a_context_error_warns_and_the_next_plan_is_taken() -> None:
    lines: list[str] = []
    program = ("!go(0).\n+!go(X) : 10 / X > 1 <- .print(first).\n"
               "+!go(X) <- .print(second).\n")
    agent = Agent(program, name="err", out=lines.append)
    agent.run_until_idle()
    assert lines == ["second"]


def test_a_plan_added_at_run_time_is_selected_by_the_next_event() -> None:
    lines: list[str] = []
    program = """
!a. !b.
+!a <- !p(1); .add_plan({+!p(X) : X > 0 <- .print(added(X))}, self, begin); !p(2).
+!p(X) <- .print(old(X)).
+!b <- .remove_plan(p__3); !p(3).
"""
    agent = Agent(program, name="dyn", out=lines.append)
    agent.run_until_idle()
    assert lines[0] == "old(1)"
    assert "added(2)" in lines
