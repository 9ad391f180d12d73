"""A sub-goal or belief event that a body posts while no other event is queued is
handled at once (`Runtime.intend_now`) instead of going through the event queue: the
same cycles, the same interleaving of intentions, the same failures and warnings as
when every event takes the queue (the reference: `ownevent.AT_ONCE` off)."""

from __future__ import annotations

import logging
from typing import Any

import pytest

from mrss.agentspeak import ownevent
from mrss.agentspeak.agent import Agent
from mrss.agentspeak.runtime import Runtime
from mrss.agentspeak.terms import Struct

PROGRAMS = {
    "interleaved": """!a. !b.
+!a <- .print(a1); !e; .print(a2); +x(a); .print(a3); -x(a); .print(a4); !f(1); .print(a5).
+!b <- .print(b1); !e; .print(b2); +x(b); .print(b3); -x(b); .print(b4); !f(2); .print(b5).
+!e.
+!f(N) : N > 1 <- .print(f, N).
+!f(N) <- !e.
+x(W) <- .print(got, W).
-x(W).
""",
    "recursion": """!count(0). !other.
+!count(10) <- .print(done).
+!count(N) <- .print(N); !count(N + 1).
+!other <- .print(o1); .print(o2); .print(o3).
""",
    "failure": """!g. !h.
+!g <- .print(g1); !missing(1); .print(never).
+!h <- .print(h1); !sub; .print(h2).
+!sub : false <- true.
-!g[error(E)] <- .print(failed, E).
-!h[error(E)] <- .print(hfailed, E).
""",
    "context error": """!g.
+!g <- !p(0); .print(after).
+!p(X) : 1 / X > 0 <- .print(div).
+!p(X) <- .print(fallback).
""",
    "atomic": """!a. !b.
+!a <- .print(a1); !at; .print(a2).
+!b <- .print(b1); .print(b2); .print(b3).
@at[atomic] +!at <- .print(at1); .print(at2).
""",
    "plans change": """!start.
+!start <- +b(1); !g(2); .add_plan({@lb +b(X) <- .print(saw, X)}); +b(2);
    .add_plan({-!g(X) <- .print(handled, X)}); !g(2); !g(-1); .remove_plan(lb); +b(3);
    .print(end).
+!g(0) <- .print(g0).
+!g(N) : N > 0 <- .print(g, N); !g(N - 1).
""",
    "tail calls": """!a(3). !b(3).
+!a(0).
+!a(N) : N > 0 <- !other(N).
+!other(N) <- !a(N - 1).
+!b(0).
+!b(N) : N > 0 <- .print(b, N); !b(N - 1).
-!b(N) <- .print(failed, N).
""",
    "belief events": """!a. !b.
+!a <- +p(1); +p(1); -p(2); -p(1); -+q(1); -+q(2); .print(a).
+!b <- .print(b1); +p(3); .print(b2).
+p(X) <- .print(plus, X).
-p(X) <- .print(minus, X).
+q(X) <- .print(q, X).
-q(X) <- .print(unq, X).
""",
}


def _run(src: str) -> tuple[list[str], int, list[str]]:
    out: list[str] = []
    agent = Agent(src, out=out.append)
    busy = agent.run_until_idle()
    return out, busy, agent.beliefs()


@pytest.mark.parametrize("name", sorted(PROGRAMS))
def test_same_as_through_the_queue(name: str, monkeypatch: pytest.MonkeyPatch,
                                   caplog: pytest.LogCaptureFixture) -> None:
    src = PROGRAMS[name]
    with caplog.at_level(logging.WARNING, logger="mrss.agentspeak"):
        fused = _run(src)
    fused_log = [r.getMessage() for r in caplog.records]
    caplog.clear()
    monkeypatch.setattr(ownevent, "AT_ONCE", False)
    monkeypatch.setattr(Runtime, "intend_now", lambda *args, **kwargs: False)
    with caplog.at_level(logging.WARNING, logger="mrss.agentspeak"):
        queued = _run(src)
    assert fused == queued
    assert fused_log == [r.getMessage() for r in caplog.records]
    assert fused[0], "the program printed something"


def _depths(src: str, monkeypatch: pytest.MonkeyPatch) -> list[tuple[int, int]]:
    """(intention, stack depth) each time a formula is about to run: the plan an event
    pushes is on the stack by then, whether the event was handled at once or queued."""
    seen: list[tuple[int, int]] = []
    run_step = Runtime.run_step

    def recording(rt: Runtime, it: Any) -> None:
        seen.append((it.id, len(it.stack)))
        run_step(rt, it)

    monkeypatch.setattr(Runtime, "run_step", recording)
    Agent(src, out=lambda _: None).run_until_idle()
    monkeypatch.setattr(Runtime, "run_step", run_step)
    return seen


@pytest.mark.parametrize("name", sorted(PROGRAMS))
def test_stacks_as_through_the_queue(name: str, monkeypatch: pytest.MonkeyPatch) -> None:
    """The tail-recursion optimisation (and where it must not apply: a `-!g` plan, a
    tail call to another goal) is the queue's: each formula runs on as deep a stack."""
    fused = _depths(PROGRAMS[name], monkeypatch)
    monkeypatch.setattr(ownevent, "AT_ONCE", False)
    assert fused == _depths(PROGRAMS[name], monkeypatch)
    assert fused


def test_a_context_error_is_warned_once(caplog: pytest.LogCaptureFixture) -> None:
    with caplog.at_level(logging.WARNING, logger="mrss.agentspeak"):
        out, _, _ = _run(PROGRAMS["context error"])
    assert out == ["fallback", "after"]
    warnings = [r.getMessage() for r in caplog.records if "error in the context" in
                r.getMessage()]
    assert len(warnings) == 1, warnings


def test_recursion_stays_flat() -> None:
    """Tail recursion handled at once still replaces the frame (the stack stays one
    plan deep below the recursion's root)."""
    depth: list[int] = []
    agent = Agent("!count(0).\n+!count(500).\n"
                  "+!count(N) <- .my_name(_); !count(N + 1).\n", out=lambda _: None)
    while agent.step():
        for it in agent.intentions.values():
            depth.append(len(it.stack))
    assert depth and max(depth) == 1


class _Holding:
    """Keeps every environment action open: the intention waits on it."""

    def __init__(self) -> None:
        self.handles: list[int] = []

    def execute(self, action: Struct, intention_id: int) -> int:
        self.handles.append(len(self.handles) + 1)
        return self.handles[-1]

    def cancel(self, handle: object) -> None:
        pass


def _depth_at_the_action(agent: Agent, host: _Holding, goal: str) -> int:
    agent.add_goal(goal)
    agent.run_until_idle()
    (it,) = agent.intentions.values()
    depth = len(it.stack)
    agent.complete_action(host.handles[-1], True)
    agent.run_until_idle()
    assert not agent.intentions
    return depth


def test_tail_calls_follow_plan_changes() -> None:
    """What a formula keeps of the plan library (`ownevent`) is asked again after a plan
    is added or removed: a `-!g` plan turns g's tail-recursion optimisation off (the
    frames stay for the handler), its removal turns it on again."""
    host = _Holding()
    out: list[str] = []
    agent = Agent("+!g(0) <- act.\n+!g(N) : N > 0 <- !g(N - 1).\n"
                  "+!learn <- .add_plan({@h -!g(_) <- .print(handled)}).\n"
                  "+!forget <- .remove_plan(h).\n", host=host, out=out.append)
    assert _depth_at_the_action(agent, host, "g(5)") == 1
    agent.add_goal("learn")
    agent.run_until_idle()
    assert _depth_at_the_action(agent, host, "g(5)") == 6
    agent.add_goal("forget")
    agent.run_until_idle()
    assert _depth_at_the_action(agent, host, "g(5)") == 1
    assert out == []


def test_belief_events_follow_plan_changes() -> None:
    out: list[str] = []
    agent = Agent("+!go(X) <- +b(X); -b(X).\n"
                  "+!learn <- .add_plan({@p +b(X) <- .print(plus, X)});\n"
                  "    .add_plan({@m -b(X) <- .print(minus, X)}).\n"
                  "+!forget <- .remove_plan(p); .remove_plan(m).\n", out=out.append)
    for goal in ("go(1)", "learn", "go(2)", "forget", "go(3)"):
        agent.add_goal(goal)
        agent.run_until_idle()
    assert out == ["plus2", "minus2"]
