"""The Python API a reasoner uses: project internal actions, goals, action failure."""

from __future__ import annotations

import itertools
from collections.abc import Hashable
from typing import Any

from mrss.agentspeak.agent import Agent, default_registry
from mrss.agentspeak.registry import IAContext
from mrss.agentspeak.terms import Struct, term_str


def test_projects_register_their_own_internal_actions() -> None:
    registry = default_registry().child()

    def double(ctx: IAContext, args: list[Any]) -> bool:
        return ctx.unify(args[1], args[0] * 2)

    registry.register(".double", double, min_args=2, max_args=2)
    out: list[str] = []
    agent = Agent("!g.\n+!g <- .double(21, X); .print(X).", actions=registry, out=out.append)
    agent.run_until_idle()
    assert out == ["42"]
    assert default_registry().get(".double") is None      # the standard library is untouched


class FailingHost:
    def __init__(self) -> None:
        self.ids = itertools.count(1)
        self.actions: list[str] = []

    def execute(self, action: Struct, intention_id: int) -> Hashable:
        self.actions.append(term_str(action))
        return next(self.ids)

    def cancel(self, handle: Hashable) -> None:
        pass


def test_failed_action_posts_goal_failure_with_action_failed() -> None:
    host = FailingHost()
    out: list[str] = []
    src = """+!fly(R) <- takeoff(R); .print("flying").
-!fly(R)[error(E), error_msg(M)] <- .print(R, " failed: ", E).
"""
    agent = Agent(src, host=host, out=out.append)
    agent.add_goal("fly(uav1)")
    agent.run_until_idle()
    assert host.actions == ["takeoff(uav1)"]
    assert agent.snapshot()["intentions"][0]["state"] == "waiting_action"
    agent.complete_action(1, False, "battery low")
    agent.run_until_idle()
    assert out == ["uav1 failed: action_failed"]
    assert agent.is_idle()


def test_next_deadline_reports_the_earliest_wait() -> None:
    now = [50.0]
    agent = Agent("!a.\n!b.\n+!a <- .wait(3000).\n+!b <- .wait(1000).", clock=lambda: now[0])
    agent.run_until_idle()
    assert agent.next_deadline() == 51.0
    assert not agent.wait_for_work(0.01)
    now[0] = 51.5
    assert agent.wait_for_work(0.01)
    agent.run_until_idle()
    assert agent.next_deadline() == 53.0


class QueryHost(FailingHost):
    open_actions = frozenset({"query"})


def test_open_action_binds_its_free_variables_from_the_result() -> None:
    host = QueryHost()
    out: list[str] = []
    src = """+!g <- query(nearest_base, [uav1], B); .print("base ", B).
-!g[error(E)] <- .print("failed ", E)."""
    agent = Agent(src, host=host, out=out.append)
    agent.add_goal("g")
    agent.run_until_idle()
    assert host.actions[0].startswith("query(nearest_base,[uav1],")
    agent.complete_action(1, True, result="query(nearest_base, [uav1], base2)")
    agent.run_until_idle()
    assert out == ["base base2"]


def test_open_action_result_that_does_not_match_fails_the_action() -> None:
    host = QueryHost()
    out: list[str] = []
    src = """+!g <- query(f, [], 7); .print("ok").
-!g[error(E)] <- .print("failed ", E)."""
    agent = Agent(src, host=host, out=out.append)
    agent.add_goal("g")
    agent.run_until_idle()
    agent.complete_action(1, True, result="query(f, [], 8)")
    agent.run_until_idle()
    assert out == ["failed action_failed"]


def test_free_variable_in_an_ordinary_action_still_fails() -> None:
    host = QueryHost()
    out: list[str] = []
    agent = Agent("+!g <- move(X).\n-!g[error(E)] <- .print(E).", host=host, out=out.append)
    agent.add_goal("g")
    agent.run_until_idle()
    assert host.actions == []
    assert out == ["action_failed"]


def test_wait_for_a_goal_event_with_an_annotated_variable_binds_goal_and_source() -> None:
    out: list[str] = []
    src = """\
!w. !kick.
+!w <- .wait({+!T[source(A)]}); .print(T, " from ", A).
+!kick <- !go(1).
+!go(X) <- true.
"""
    agent = Agent(src, out=out.append)
    agent.run_until_idle()
    assert out == ["go(1) from self"]
