"""Events matched against plan triggers: the fast paths (a trigger of plain variables,
a trigger of numbers and strings) decide as unification does."""

from __future__ import annotations

from mrss.agentspeak.agent import Agent

PROGRAM = """
!g(0). !g(1). !g(s). !g("s"). !g(0.0). !g(f(0)). !t.
+!g(0) <- .print(zero).
+!g(1.0) <- .print(one).
+!g("s") <- .print(str).
+!g(X) <- .print(other(X)).
+!t <- !g(Y); .print(bound(Y)); !h(2, Z); .print(Z).
+!h(2, "two") <- true.
"""


def test_constant_triggers_match_as_unification_does() -> None:
    lines: list[str] = []
    Agent(PROGRAM, name="trig", out=lines.append).run_until_idle()
    # 1 matches 1.0, an atom is not a string, a free variable is bound by the trigger
    assert lines == ["zero", "one", "other(s)", "str", "zero", "other(f(0))", "zero",
                     "bound(0)", "two"]
