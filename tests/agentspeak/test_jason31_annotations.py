"""Unification with annotations as Jason 3.1 does it (Unifier.unifiesNoUndo): the
annotations of the first term must be a subset of the second's -- AGENTSPEAK.md's rule
for a plan's trigger ("the trigger's annotations are a subset of the event's"), which
Jason applies to every unification: `=`, `.member`, arguments, list items. A variable
with annotations (`X[y]`) takes the other literal without its annotations; a free one
has none, so `X[y]` never unifies with a free variable; a number, a string, a list and
an atom written as an argument or a list item (Jason's Atom class, which is no Pred) are
taken with no test, while an atom at the top of `=` is tested (`W[y] = a` fails).
The expected lines are what Jason 3.1 printed for the program."""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

from mrss.agentspeak.agent import Agent

PROGRAM = """\
!g.
+!g <- for (.member(X[y], [a, p(1), "s", 3, [1], ~n, p(2)[z], q[y,z]])) { .print(m(X)) };
   if (b[x,y] = Z[y]) { .print(z(Z)) } else { .print(nz) };
   if (p(1) = W[y]) { .print(w(W)) } else { .print(nw) };
   if (W3[y] = a) { .print(w3(W3)) } else { .print(nw3) };
   if (q[y] = W5[y,z]) { .print(w5(W5)) } else { .print(nw5) };
   if (W6[y] = W7[y,z]) { .print(w67) } else { .print(nw67) };
   X8 = p(8)[k]; if (X8 = W8[y]) { .print(w8(W8)) } else { .print(nw8) };
   if (.member(X10[y], [W11])) { .print(m10) } else { .print(nm10) };
   if (p(a) = p(X1[y])) { .print(a1(X1)) } else { .print(na1) };
   if ([b[y,z]] = [X2[y]]) { .print(a2(X2)) } else { .print(na2) };
   if (X5[y|T5] = b[y,z]) { .print(a5(X5,T5)) } else { .print(na5) };
   if (f(c[s,t]) = f(X9[s])) { .print(a9(X9)) } else { .print(na9) };
   .findall(Y, .member(Y[s], [c[s], d[t], e, f(1), "x", [c[s]]]), L); .print(L);
   !h(k[m]); !h(k); !h(k[n]).
+!h(X[m]) <- .print(h1(X)).
+!h(X) <- .print(h2(X)).
"""

JASON = ["m(a)", 'm("s")', "m(3)", "m([1])", "m(q)", "nz", "w(p(1))", "nw3", "w5(q)", "w67",
         "nw8", "nm10", "a1(a)", "na2", "a5(b,[z])", "na9", '[c,e,"x",[c[s]]]', "h1(k)",
         "h1(k)", "h2(k[n])"]


# A belief query with annotations and no tail tries each set of that many annotations
# of a fact, in order (Literal.logicalConsequence's nbAnnots, ListTermImpl.subSets):
# every source of a belief, every annotation for c[A].
QUERIES = """\
c[deadline(10),priority(high)].
p(1)[source(a)].
!g.
+!g <- +p(1)[source(b)]; +p(2)[source(c),x];
   .findall(A, c[A], L); .print(L);
   .findall(f(A,B), c[A,B], L2); .print(L2);
   .findall(S, p(1)[source(S)], L3); .print(L3);
   .findall(pair(N,S), p(N)[source(S)], L4); .print(L4);
   ?p(1)[source(S1)]; .print(S1);
   .findall(N, p(N)[x], L5); .print(L5);
   .findall(N, p(N)[x,source(c)], L6); .print(L6);
   .findall(Q, c[priority(Q)], L7); .print(L7);
   .findall(z, c[A1,B1,C1], L8); .print(L8);
   .findall(z, c[A2,B2,C2,D2], L9); .print(L9);
   .count(p(_)[source(_)], K); .print(K);
   if (p(1)[source(S2)] & S2 \\== a) { .print(S2) }.
"""

JASON_QUERIES = ["[deadline(10),priority(high),source(self)]",
                 "[f(deadline(10),priority(high)),f(deadline(10),source(self)),"
                 "f(priority(high),source(self))]", "[a,b]",
                 "[pair(2,c),pair(1,a),pair(1,b)]", "a", "[2]", "[2]", "[high]", "[z]", "[]",
                 "3", "b"]


def test_a_query_with_annotations_gives_each_matching_set_as_in_jason() -> None:
    out: list[str] = []
    Agent(QUERIES, file="queries.asl", out=out.append).run_until_idle()
    assert out == JASON_QUERIES


def test_annotated_terms_unify_as_in_jason() -> None:
    out: list[str] = []
    Agent(PROGRAM, file="annots.asl", out=out.append).run_until_idle()
    assert out == JASON


def test_mrss_agent_unifies_annotated_terms_as_jason(tmp_path: Path) -> None:
    (tmp_path / "annots.asl").write_text(PROGRAM, encoding="utf-8")
    proc = subprocess.run([sys.executable, "-m", "mrss", "agent", "annots.asl",
                           "--max-time", "20"], cwd=tmp_path, capture_output=True,
                          text=True, timeout=60)
    assert proc.returncode == 0, proc.stderr
    assert proc.stdout.splitlines() == JASON
