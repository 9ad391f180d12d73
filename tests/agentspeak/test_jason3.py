"""Jason 3 features beyond the conformance programs: what needs a host that holds an
action open, a clock the test moves, or the load-time refusals of what is left out."""

from __future__ import annotations

from collections.abc import Hashable

import pytest

from mrss.agentspeak.agent import Agent
from mrss.agentspeak.errors import AslSyntaxError
from mrss.agentspeak.terms import ADD_ACH, GOAL_STATE, Struct, term_str


class HoldingHost:
    """Keeps every action open until the test completes it."""

    def __init__(self) -> None:
        self.open: dict[Hashable, str] = {}
        self._n = 0

    def execute(self, action: Struct, intention_id: int) -> Hashable:
        self._n += 1
        self.open[self._n] = term_str(action)
        return self._n

    def cancel(self, handle: Hashable) -> None:
        self.open.pop(handle, None)


SUSPEND_WHILE_ACTING = """
!worker.
+!worker <- move(a); +moved; .print(worker_done).
+!pause <- .suspend(worker); ?reason_of(R); .print(paused(R)).
+!go_on <- .resume(worker).
reason_of(R) :- .suspended(worker, R).
^!worker[state(S)[reason(R)]] <- .print(state(S, R)).
"""


def test_an_intention_suspended_during_its_action_goes_on_only_when_resumed() -> None:
    host = HoldingHost()
    lines: list[str] = []
    agent = Agent(SUSPEND_WHILE_ACTING, file="w.asl", host=host, out=lines.append)
    agent.run_until_idle()
    assert list(host.open.values()) == ["move(a)"]
    agent.add_goal("pause")
    agent.run_until_idle()
    # Jason's suspended.java looks in the pending actions first: the reason is `act`
    # while the action runs, though `.suspend` suspended it too
    assert "paused(act)" in lines
    (handle,) = host.open
    agent.complete_action(handle, True)  # the action ends while it is suspended
    agent.run_until_idle()
    assert not agent.believes("moved") and "worker_done" not in lines
    agent.add_goal("go_on")
    agent.run_until_idle()
    assert agent.believes("moved")
    assert lines[-3:] == ["worker_done", 'state(achieved,"")', 'state(finished,"")']
    states = [line for line in lines if line.startswith("state(")]
    assert states == ['state(pending,"")', 'state(executing,"")',
                      "state(waiting,action(move(a)))", "state(suspended,suspend_ia)",
                      "state(resumed,resume_ia)", 'state(achieved,"")', 'state(finished,"")']


def test_goal_state_events_are_posted_only_for_predicates_with_a_meta_plan() -> None:
    agent = Agent("!a. !b.\n+!a <- true.\n+!b <- true.\n^!a[state(S)] <- +seen(S).\n",
                  file="m.asl", out=lambda line: None)
    agent.run_until_idle()
    assert sorted(agent.beliefs()) == sorted(f"seen({s})[source(self)]" for s in
                                             ("pending", "executing", "achieved", "finished"))
    meta_a = "+!a <- true.\n+!b <- true.\n^!a[state(S)] <- true.\n"
    for goal, ops in (("a", [GOAL_STATE, ADD_ACH]), ("b", [ADD_ACH])):
        queued = Agent(f"!{goal}.\n" + meta_a, file="q.asl", out=lambda line: None)
        assert [ev.op for ev in queued.events] == ops  # `pending`, first, only for a


def test_at_fires_on_the_agents_clock() -> None:
    now = [100.0]
    lines: list[str] = []
    agent = Agent('!s.\n+!s <- .at("now +3 s", {+!later}); .at(500, {+tick}).\n'
                  '+!later <- .print(later).\n+tick <- .print(tick).\n', file="at.asl",
                  clock=lambda: now[0], out=lines.append)
    agent.run_until_idle()
    assert lines == [] and agent.next_deadline() == 100.5 and not agent.is_idle()
    now[0] = 101.0
    agent.run_until_idle()
    assert lines == ["tick"] and agent.next_deadline() == 103.0
    now[0] = 103.0
    agent.run_until_idle()
    assert lines == ["tick", "later"] and agent.is_idle()


@pytest.mark.parametrize(("call", "reason"), [
    (".set.create(S)", "Java sets hold a mutable Java object"),
    (".map.put(M, a, 1)", "Java maps hold a mutable Java object"),
    (".df_register(fire)", "it needs other agents: run several"),
    (".stopMAS", "agents are started and stopped by MRSS's supervisor"),
    (".signal(a, b)", "signals come from a Java environment"),
    (".foreach(b(X), true)", "it is the implementation of for (...)"),
    (".verbose(2)", "the log level is set by MRSS's logging configuration"),
])
def test_what_is_left_out_of_jasons_library_is_refused_with_the_reason(
        call: str, reason: str) -> None:
    with pytest.raises(AslSyntaxError) as info:
        Agent(f"!g.\n+!g <- .print(x);\n   {call}.\n", file="u.asl")
    (problem,) = info.value.problems
    assert (problem.line, problem.col) == (3, 4)
    name = call.split("(")[0]
    assert problem.message.startswith(f"`{name}` is not supported: {reason}")


def test_the_agent_object_keeps_cpythons_fast_attribute_access() -> None:
    # CPython shares an instance's attribute keys (fast access) up to 30 of them: the
    # 30th cost every cycle about 10% once; rarely used state goes in `agent.extras`
    agent = Agent("+!g <- true.\n", file="x.asl", out=lambda line: None)
    assert len(vars(agent)) < 30, sorted(vars(agent))
