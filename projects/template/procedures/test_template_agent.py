"""The agent's decisions on the real interpreter with a scripted RCL (fast, no processes).

ADAPT: one test per decision of your agent.asl. `ScriptedHost` keeps every environment
action open until the test ends it: `finish(prefix)` succeeds it, `finish(prefix,
ok=False, error=Cause)` fails it with a FailureCause value, as the RCL would.
"""

from __future__ import annotations

from pathlib import Path

import pytest

from mrss.api.testing import Agent, ScriptedHost

AGENT = Path(__file__).resolve().parent.parent / "agent.asl"
G1 = "move(robot1,g1,48.209,16.3745)"


@pytest.fixture()
def world() -> tuple[Agent, ScriptedHost]:
    host = ScriptedHost(virtual_time=True)  # the retries' .wait pauses are not waited out
    return host.load(AGENT, name="template"), host


def test_a_goal_is_retried_for_a_retryable_cause_a_few_times_and_a_plain_failure_ends_it(
        world: tuple[Agent, ScriptedHost]) -> None:
    agent, rcl = world
    rcl.feed("goto_received(g1, 48.2090, 16.3745)")
    assert list(rcl.open.values()) == [G1]
    for attempt, cause in enumerate(("link_down", "transient", "failsafe")):
        rcl.finish("move(robot1,g1", ok=False, error=cause)   # tried again a second later
        rcl.run_until(lambda: bool(rcl.open))
        assert list(rcl.open.values()) == [G1] and agent.believes("busy(robot1, g1)")
        assert agent.believes(f"tried(g1, {attempt + 1})")
    rcl.finish("move(robot1,g1", ok=False, error="link_down")  # the fourth: given up
    agent.run_until_idle()
    assert not rcl.open and agent.believes("free(robot1)")
    assert not agent.believes("tried(g1, _)")                  # forgotten with the goal

    rcl.feed("goto_received(g2, 48.2090, 16.3745)")
    rcl.finish("move(robot1,g2", ok=False)                     # action_failed: not retried
    agent.run_until_idle()
    assert not rcl.open and agent.believes("free(robot1)")


def test_a_goal_cancelled_while_its_retry_waits_is_not_started_again(
        world: tuple[Agent, ScriptedHost]) -> None:
    agent, rcl = world
    rcl.feed("goto_received(g1, 48.2090, 16.3745)")
    rcl.finish("move(robot1,g1", ok=False, error="link_down")  # again in 1 s
    agent.run_until_idle()
    rcl.feed("goal_cancelled(g1)")                              # meanwhile: cancelled
    mark = len(rcl.log)
    rcl.run_until(lambda: not agent.snapshot()["intentions"])
    assert rcl.since(mark) == [] and not rcl.open and agent.believes("free(robot1)")


def test_an_inspection_is_addressed_to_a_role_and_a_reassignment_does_not_fail_it(
        world: tuple[Agent, ScriptedHost]) -> None:
    agent, rcl = world
    rcl.feed("inspect_received(i1, 48.2086, 16.3742)")
    assert list(rcl.open.values()) == ["move(any([ground],at(48.2086,16.3742)),i1,48.2086,"
                                       "16.3742)"]
    rcl.feed("reassigned(move(any([ground],at(48.2086,16.3742)),i1,48.2086,16.3742),"
             "robot1,robot2)")                                # the RCL handed it on
    agent.run_until_idle()
    assert len(rcl.open) == 1 and not agent.believes("reassigned(_, _, _)")
    rcl.finish("move(any([ground]")
    agent.run_until_idle()
    assert not rcl.open and not agent.believes("inspect_received(i1, _, _)")

    rcl.feed("inspect_received(i2, 48.2090, 16.3745)")
    rcl.finish("move(any([ground]", ok=False, error="action_failed")  # failed for good
    agent.run_until_idle()
    assert not rcl.open and not agent.believes("inspect_received(i2, _, _)")
