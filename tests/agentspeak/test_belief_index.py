"""The first-argument index of the belief base gives a query exactly the answers, in
exactly the order, of a scan of all the predicate's facts -- through adds in front
and at the end, annotation merges, removals and facts the index cannot key."""

from __future__ import annotations

import random
from typing import Any

from mrss.agentspeak.agent import Agent
from mrss.agentspeak.beliefs import INDEX_FROM, NO_KEY, first_key
from mrss.agentspeak.formulas import LiteralQuery
from mrss.agentspeak.terms import Struct, Var, rename, term_str, value
from mrss.agentspeak.unify import undo, unify

FIRSTS: list[Any] = [1, 2, 2.0, "a", Struct("a"), Struct("b")]
UNKEYED: list[Any] = [Struct("a", annots=(Struct("x"),)), Struct("f", (1,))]
QUERIES: list[Any] = [1, 2, 1.0, "a", Struct("a"), Struct("b"), Struct("c"), "zz"]


def _scan(agent: Agent, query: Struct) -> list[str]:
    store = agent.bb.store(("p", 2, False))
    out: list[str] = []
    trail: list[Any] = []
    for b in store.facts() if store is not None else ():
        if unify(query, None, b if b.ground else rename(b), trail):
            out.append(term_str(value(query)))
        undo(trail, 0)
    return out


def _answers(agent: Agent, query: Struct) -> list[str]:
    out = [term_str(value(query)) for _ in LiteralQuery(query).solve(agent, None)]
    agent.trail.clear()
    return out


def test_indexed_queries_answer_as_a_full_scan() -> None:
    rng = random.Random(12)
    agent = Agent("", name="index", out=lambda _: None)
    indexed = 0
    unkeyed_seen = False
    for step in range(3000):
        first = rng.choice(FIRSTS)
        if 1000 <= step < 1500 and rng.random() < 0.2:  # facts the index cannot key
            first = rng.choice(UNKEYED) if rng.random() < 0.7 else Var("V")
        if step == 1500:  # ... all gone again: the index answers again
            agent.bb.abolish(("p", 2, False), keep=lambda b: first_key(b.args[0]) is not NO_KEY)
        args = (first, rng.randrange(12))
        source = Struct("source", (Struct(rng.choice(["self", "percept", "other"])),))
        lit = Struct("p", args, (source,))
        if rng.random() < 0.6:
            agent.bb.add(lit, front=rng.random() < 0.7)
        else:
            agent.bb.remove(lit)
        if step % 7:
            continue
        for q in QUERIES:
            query = Struct("p", (q, Var("X")))
            assert _answers(agent, query) == _scan(agent, query), (step, term_str(query))
        store = agent.bb.store(("p", 2, False))
        if store is not None and store.first is not None and not store.irregular:
            indexed += 1
        if store is not None and store.irregular:
            unkeyed_seen = True
            assert step < 1500
    assert indexed > 300 and unkeyed_seen  # the index answered, and stood aside


def test_a_small_predicate_is_not_indexed() -> None:
    agent = Agent("", name="index", out=lambda _: None)
    for i in range(INDEX_FROM - 1):
        agent.bb.add(Struct("p", (i, i)))
    assert _answers(agent, Struct("p", (3, Var("X")))) == ["p(3,3)"]
    assert agent.bb.store(("p", 2, False)).first is None  # type: ignore[union-attr]


def test_plan_contexts_use_the_index_with_bound_slots() -> None:
    lines: list[str] = []
    program = """
!start.
+!start <- for (.range(I, 0, 99)) { +at(I mod 10, I) }; !look(3); !look(7); !look(42).
+!look(R) : .findall(P, at(R, P), L) <- .print(R, " ", L).
"""
    Agent(program, name="ctx", out=lines.append).run_until_idle()
    assert lines == [
        "3 [93,83,73,63,53,43,33,23,13,3]",
        "7 [97,87,77,67,57,47,37,27,17,7]",
        "42 []",
    ]


def test_a_key_with_one_fact_at_the_end_then_more() -> None:
    agent = Agent("", name="index", out=lambda _: None)
    for i in range(INDEX_FROM + 4):
        agent.bb.add(Struct("p", (i, 0)), front=False)  # initial beliefs: at the end
    query = Struct("p", (3, Var("X")))
    assert _answers(agent, query) == ["p(3,0)"]  # builds the index: one fact per key
    agent.bb.add(Struct("p", (3, 1)), front=True)
    agent.bb.add(Struct("p", (3, 2)), front=False)
    assert _answers(agent, query) == _scan(agent, query) == ["p(3,1)", "p(3,0)", "p(3,2)"]
    agent.bb.remove(Struct("p", (3, 0)))
    agent.bb.remove(Struct("p", (3, 1)))
    assert _answers(agent, query) == _scan(agent, query) == ["p(3,2)"]
