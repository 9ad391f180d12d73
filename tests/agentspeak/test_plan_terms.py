"""Plan terms as values: closing over the enclosing plan's bindings, their text read
back as a plan, and bad `.add_plan` arguments failing only their intention."""

from __future__ import annotations

import logging

import pytest

from mrss.agentspeak.agent import Agent


def _run(src: str) -> list[str]:
    out: list[str] = []
    Agent(src, file="p.asl", out=out.append).run_until_idle()
    return out


def test_a_plan_term_takes_bound_values_and_keeps_free_variables_its_own() -> None:
    out = _run("""\
!s.
+!s <- N = 2; P = { +!a(X) : X > N <- if (X > 5) { .print(big(X)) } else { .print(X) } };
    .print(P); .add_plan(P); !a(3); !a(9); !a(1).
-!a(X) <- .print(none(X)).
""")
    assert out == ["{ +!a(X) : (X > 2) <- if (X > 5) { .print(big(X)) } else { .print(X) } }",
                   "3", "big(9)", "none(1)"]


def test_the_text_of_a_plan_term_reads_back_as_the_same_plan() -> None:
    out = _run("""\
!s.
+!s <- P = { @p +!a(X) : b(X) & not c <- for (.member(Y, [1, 2])) { .print(Y) };
                                        -+c(X); !!d; ?e(X) }; .print(P).
""")
    assert out == ["{ @p +!a(X) : (b(X) & not (c)) <- for (.member(Y,[1,2])) "
                   "{ .print(Y) }; -+c(X); !!d; ?e(X) }"]
    again = _run(out[0][2:-2] + ".\n!s.\n+!s <- .relevant_plans({+!a(_)}, [Q]); .print(Q).\n")
    # as Jason 3.1's .relevant_plans, the label carries the plan's source
    assert again == [out[0].replace("{ @p ", "{ @p[source(self)] ")]


def test_plan_terms_sort_and_test_like_other_terms() -> None:
    out = _run("""\
!s.
+!s <- P = { +!a <- true }; .sort([P, 1, a], L); .length(L, N); .print(N);
    if (.ground(P)) { .print(ground) }; .add_plan([P, "+!b <- .print(b)."]); !b.
""")
    assert out == ["3", "ground", "b"]


def test_add_plan_of_a_number_fails_the_intention(caplog: pytest.LogCaptureFixture) -> None:
    with caplog.at_level(logging.WARNING, logger="mrss.agentspeak"):
        out = _run("!s.\n+!s <- .add_plan(3); .print(never).\n")
    assert out == []
    assert "p.asl:2: .add_plan: expected a plan term or a string with a plan, not 3" in \
        "\n".join(r.getMessage() for r in caplog.records)
