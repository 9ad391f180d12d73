"""The paper's Listing 1 with a host that keeps `cover` actions running until told.

Listing 1 perceives goals for the UAV "dl" but its initial beliefs name "rl"; as in a
Jason `.mas2j` (`beliefs=`), the agent is given `isuav("dl")` and `available("dl")` as
extra initial beliefs. The listing text itself is unchanged.
"""

from __future__ import annotations

import itertools
import json
import logging
import threading
from collections.abc import Hashable
from pathlib import Path

import pytest

from mrss.agentspeak.agent import Agent
from mrss.agentspeak.terms import Struct, term_str
from mrss.testing import wait_until

LISTING = Path(__file__).parent / "listing1.asl"
UAV = ['isuav("dl")', 'available("dl")']


class HoldingHost:
    """Records actions and cancellations; actions finish only when the test says so."""

    def __init__(self) -> None:
        self.lock = threading.Lock()
        self.started: list[tuple[int, str]] = []
        self.cancelled: list[int] = []
        self._ids = itertools.count(1)

    def execute(self, action: Struct, intention_id: int) -> Hashable:
        with self.lock:
            handle = next(self._ids)
            self.started.append((handle, term_str(action)))
            return handle

    def cancel(self, handle: Hashable) -> None:
        with self.lock:
            self.cancelled.append(int(handle))  # type: ignore[call-overload]

    def handle_of(self, text: str) -> int:
        with self.lock:
            return [h for h, a in self.started if a == text][-1]

    def actions(self) -> list[str]:
        with self.lock:
            return [a for _, a in self.started]


class Clock:
    def __init__(self) -> None:
        self.now = 1000.0

    def __call__(self) -> float:
        return self.now


def make_agent(beliefs: list[str] | None = None) -> tuple[Agent, HoldingHost, Clock]:
    host = HoldingHost()
    clock = Clock()
    agent = Agent(file=LISTING, host=host, beliefs=UAV if beliefs is None else beliefs,
                  clock=clock, name="uav")
    return agent, host, clock


def goals_intended(agent: Agent) -> list[str]:
    return [it["stack"][-1]["trigger"] for it in agent.snapshot()["intentions"]]


def test_listing1_parses_unchanged_and_starts_a_cover_action() -> None:
    agent, host, _ = make_agent()
    agent.add_percept("area_goal_received(g1, 3)")
    agent.run_until_idle()
    assert host.actions() == ['cover("dl",g1)']
    beliefs = agent.beliefs()
    assert 'currenttask("dl",g1,3)[source(self)]' in beliefs
    assert not any(b.startswith('available("dl")') for b in beliefs)
    snap = agent.snapshot()
    assert json.loads(json.dumps(snap)) == snap          # plain data, ready for the bus
    assert snap["actions"] == [{"handle": "1", "intention": snap["intentions"][0]["id"]}]
    [it] = snap["intentions"]
    assert it["state"] == "waiting_action"
    assert [f["trigger"] for f in it["stack"]] == [
        '+!coverarea("dl",g1,3)[source(self)]',
        "+area_goal_received(g1,3)[source(percept)]"]


def test_higher_priority_goal_preempts_the_running_one_which_resumes_after() -> None:
    agent, host, clock = make_agent()
    agent.add_percept("area_goal_received(g1, 1)")
    agent.run_until_idle()
    h1 = host.handle_of('cover("dl",g1)')

    agent.add_percept("area_goal_received(g2, 5)")
    agent.run_until_idle()
    assert host.cancelled == [h1]                       # the low-priority cover is cancelled
    assert host.actions() == ['cover("dl",g1)', 'cover("dl",g2)']
    assert '+!coverarea("dl",g1,1)[source(self)]' in goals_intended(agent)  # re-posted, waiting

    clock.now += 2.5                                     # g1 retries while g2 still runs
    agent.run_until_idle()
    assert host.actions() == ['cover("dl",g1)', 'cover("dl",g2)']

    agent.complete_action(host.handle_of('cover("dl",g2)'), True)
    agent.run_until_idle()
    assert 'available("dl")[source(self)]' in agent.beliefs()
    clock.now += 2.5
    agent.run_until_idle()
    assert host.actions() == ['cover("dl",g1)', 'cover("dl",g2)', 'cover("dl",g1)']
    assert 'currenttask("dl",g1,1)[source(self)]' in agent.beliefs()
    agent.complete_action(host.handle_of('cover("dl",g1)'), True)
    agent.run_until_idle()
    assert agent.snapshot()["intentions"] == []
    assert 'available("dl")[source(self)]' in agent.beliefs()


def test_cancelling_drops_the_intention_and_cancels_cover_at_the_host() -> None:
    agent, host, _ = make_agent()
    agent.add_percept("area_goal_received(g1, 3)")
    agent.run_until_idle()
    h1 = host.handle_of('cover("dl",g1)')
    agent.add_percept("goal_cancelled(g1)")
    agent.run_until_idle()
    assert host.cancelled == [h1]
    assert agent.snapshot()["intentions"] == []
    beliefs = agent.beliefs()
    assert 'available("dl")[source(self)]' in beliefs
    assert not any(b.startswith("currenttask") for b in beliefs)
    agent.complete_action(h1, True)                      # late feedback is ignored
    agent.run_until_idle()
    assert host.actions() == ['cover("dl",g1)']


def test_priority_change_reposts_the_goal() -> None:
    agent, host, _ = make_agent()
    agent.add_percept("area_goal_received(g1, 3)")
    agent.run_until_idle()
    h1 = host.handle_of('cover("dl",g1)')
    before = [it["id"] for it in agent.snapshot()["intentions"]]

    agent.add_percept("prioritychange(g1, 7)")           # .intend(coverarea(R,g1,7)) fails
    agent.run_until_idle()
    assert host.cancelled == []

    agent.add_percept("prioritychange(g1, 3)")           # matches: drop and re-post
    agent.run_until_idle()
    assert host.cancelled == [h1]
    snap = agent.snapshot()
    assert [it["id"] for it in snap["intentions"]] != before
    assert goals_intended(agent) == ['+!coverarea("dl",g1,3)[source(self)]']
    assert snap["intentions"][0]["waiting_on"].startswith(".wait 2000")


def test_unchanged_listing_without_dl_beliefs_fails_the_goal_like_jason(
        caplog: pytest.LogCaptureFixture) -> None:
    agent, host, _ = make_agent(beliefs=[])
    with caplog.at_level(logging.WARNING, logger="mrss.agentspeak"):
        agent.add_percept("area_goal_received(g1, 3)")
        agent.run_until_idle()
    assert host.actions() == []
    assert any('no applicable plan for +!coverarea("dl",g1,3)' in r.getMessage()
               for r in caplog.records)


def test_reasoner_loop_thread_blocks_for_work_and_takes_completions_from_other_threads() -> None:
    agent, host, _ = make_agent()
    stop = threading.Event()
    idle_cycles: list[int] = []

    def loop() -> None:
        while not stop.is_set():
            if agent.wait_for_work(0.05):
                agent.run_until_idle()
            else:
                idle_cycles.append(agent.cycle)

    thread = threading.Thread(target=loop, daemon=True)
    thread.start()
    try:
        agent.add_percept("area_goal_received(g1, 3)")
        wait_until(lambda: host.actions() == ['cover("dl",g1)'], 5, message="cover started")
        wait_until(lambda: len(idle_cycles) >= 2, 5, message="loop idles while cover runs")
        cycles = agent.cycle
        wait_until(lambda: len(idle_cycles) >= 4, 5, message="still idle")
        assert agent.cycle == cycles                       # no busy polling while blocked
        agent.complete_action(host.handle_of('cover("dl",g1)'), True)
        wait_until(lambda: not agent.intentions, 5, message="g1 finished")
        agent.add_percept("area_goal_received(g2, 1)")
        wait_until(lambda: host.actions()[-1:] == ['cover("dl",g2)'], 5, message="second cover")
    finally:
        stop.set()
        thread.join(5)
