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


@pytest.fixture()
def world() -> tuple[Agent, ScriptedHost]:
    host = ScriptedHost(virtual_time=True)  # the retries' .wait pauses are not waited out
    return host.load(AGENT, name="template_sims"), host


def test_a_goal_is_retried_for_a_retryable_cause_a_few_times_and_a_plain_failure_ends_it(
        world: tuple[Agent, ScriptedHost]) -> None:
    agent, rcl = world
    rcl.feed("goto_received(g1, ugv1, 48.2086, 16.3742)")
    assert list(rcl.open.values()) == ["drive(ugv1,g1,48.2086,16.3742)"]
    for attempt, cause in enumerate(("link_down", "transient", "failsafe")):
        rcl.finish("drive(ugv1,g1", ok=False, error=cause)   # tried again a second later
        rcl.run_until(lambda: bool(rcl.open))
        assert list(rcl.open.values()) == ["drive(ugv1,g1,48.2086,16.3742)"]
        assert agent.believes(f"tried(g1, {attempt + 1})")
    rcl.finish("drive(ugv1,g1", ok=False, error="link_down")  # the fourth: given up
    agent.run_until_idle()
    assert not rcl.open and not agent.believes("goto_received(g1, _, _, _)")
    assert not agent.believes("tried(g1, _)")                  # forgotten with the goal

    rcl.feed("goto_received(g2, uav1, 48.2090, 16.3745)")
    rcl.finish("fly(uav1,g2", ok=False)                        # action_failed: not retried
    agent.run_until_idle()
    assert not rcl.open and not agent.believes("goto_received(g2, _, _, _)")


def test_each_goal_counts_its_own_retries(world: tuple[Agent, ScriptedHost]) -> None:
    agent, rcl = world
    rcl.feed("goto_received(g1, ugv1, 48.2086, 16.3742)",
             "goto_received(g2, uav1, 48.2090, 16.3745)")
    rcl.finish("drive(ugv1,g1", ok=False, error="link_down")
    rcl.finish("fly(uav1,g2", ok=False, error="link_down")
    agent.run_until_idle()
    rcl.run_until(lambda: len(rcl.open) == 2)                  # both begun again
    rcl.finish("fly(uav1,g2", ok=False, error="transient")
    agent.run_until_idle()
    assert agent.believes("tried(g1, 1)") and agent.believes("tried(g2, 2)")
    assert not agent.believes("tried(g2, 1)")


def test_a_goal_cancelled_while_its_retry_waits_is_not_started_again(
        world: tuple[Agent, ScriptedHost]) -> None:
    agent, rcl = world
    rcl.feed("goto_received(g1, ugv1, 48.2086, 16.3742)")
    rcl.finish("drive(ugv1,g1", ok=False, error="link_down")  # again in 1 s
    agent.run_until_idle()
    rcl.feed("goal_cancelled(g1)")                             # meanwhile: cancelled
    mark = len(rcl.log)
    rcl.run_until(lambda: not agent.snapshot()["intentions"])
    assert rcl.since(mark) == [] and not rcl.open
    assert not agent.believes("goto_received(g1, _, _, _)")


def test_a_survey_is_addressed_to_a_role_and_a_reassignment_does_not_fail_it(
        world: tuple[Agent, ScriptedHost]) -> None:
    agent, rcl = world
    rcl.feed("survey_received(s1, 48.2086, 16.3742)")
    assert list(rcl.open.values()) == \
        ["fly(any([uav,camera],at(48.2086,16.3742)),s1,48.2086,16.3742)"]
    # the RCL handed the task from a lost UAV to another: the action goes on
    rcl.feed("reassigned(fly(any([uav,camera],at(48.2086,16.3742)),s1,48.2086,16.3742),"
             " uav1, uav2)")
    agent.run_until_idle()
    assert len(rcl.open) == 1 and not agent.believes("reassigned(_, _, _)")
    rcl.finish("fly(any(", ok=True)
    agent.run_until_idle()
    assert not rcl.open and not agent.believes("survey_received(s1, _, _)")

    rcl.feed("survey_received(s2, 48.2090, 16.3745)")
    rcl.finish("fly(any(", ok=False, error="rejected")     # no robot could ever take it
    agent.run_until_idle()
    assert not rcl.open and not agent.believes("survey_received(s2, _, _)")
