"""The wildfire agent's decisions, on the real interpreter with a scripted host.

mrss.api.testing.ScriptedHost records every environment action and keeps it open until
the test completes it, as the RCL would; `rcl_goal_management` is recorded and succeeds
at once, as the reasoner's host does. Goals are tasks addressed to a role: which robot
runs them, and which pre-empts which, is the RCL's allocation (tests/actors/rcl); here
the agent's part: what it asks for, at which priority, and what it does for one named
robot (service, teleop, hold). The whole system (real RCL, five robots, broker) is
exercised by test_wildfire_scenario.py and test_wildfire_fleet.py.
"""

from __future__ import annotations

from collections.abc import Hashable
from pathlib import Path
from typing import Any

import pytest

from mrss.api.testing import Agent, ScriptedHost

AGENT = Path(__file__).resolve().parent.parent / "agent.asl"
UAV = "any([uav,camera])"                   # what a cover asks of its robot
UGV = "any([ugv,water],at(-35.36,149.16))"  # ... and water for a hotspot there


class Host(ScriptedHost):
    """A scripted host that also keeps each action's `[priority(P)]` (0: none)."""

    def __init__(self) -> None:
        super().__init__(virtual_time=True)  # the retries' .wait pauses are not waited out
        self.priorities: list[tuple[str, int]] = []

    def execute(self, action: Any, intention_id: int) -> Hashable:
        handle = super().execute(action, intention_id)
        priority = next((int(str(a.args[0])) for a in action.annots or ()
                         if getattr(a, "functor", None) == "priority"), 0)
        self.priorities.append((self.log[-1], priority))
        return handle


@pytest.fixture()
def world() -> tuple[Agent, Host]:
    host = Host()
    return host.load(AGENT, name="wildfire"), host


def test_area_goals_are_asked_of_any_uav_at_their_priority(
        world: tuple[Agent, Host]) -> None:
    agent, rcl = world
    rcl.feed("area_goal_received(a1, 2)", "area_goal_received(a2, 1)")
    rcl.feed("area_goal_received(a3, 5)")
    # every goal is asked at once, addressed to a role: the RCL awards, pre-empts, waits
    assert rcl.priorities == [(f"cover({UAV},a1)", 2), (f"cover({UAV},a2)", 1),
                              (f"cover({UAV},a3)", 5)]
    assert not [e for e in rcl.log if e.startswith("rcl_goal_management")]
    assert agent.believes(f"task({UAV}, a3, 5)")
    for goal in ("a3", "a1", "a2"):
        rcl.finish(f"cover({UAV},{goal})")
        agent.run_until_idle()
    assert not rcl.open and not agent.believes("task(_, _, _)")
    # how each goal ended is said, for the dashboard's mission panel
    assert all(agent.believes(f"done_goal({g})") for g in ("a1", "a2", "a3"))


def test_goals_perceived_together_are_each_asked_once(world: tuple[Agent, Host]) -> None:
    """A restarted reasoner perceives every durable goal at once (so does a burst from the
    operator): each is asked of the RCL once, and a goal perceived again while it is
    asked is not asked twice."""
    agent, rcl = world
    rcl.feed("area_goal_received(a1, 2)", "area_goal_received(a2, 3)",
             "area_goal_received(a3, 4)", "area_goal_received(a4, 1)",
             "area_goal_received(a5, 4)")
    agent.remove_percept("area_goal_received(a3, 4)")
    rcl.feed("area_goal_received(a3, 4)")               # perceived again, still asked
    assert sorted(rcl.log) == sorted(f"cover({UAV},a{n})" for n in range(1, 6))
    assert agent.believes(f"task({UAV}, a3, 4)")


def test_cancel_and_priority_change(world: tuple[Agent, Host]) -> None:
    agent, rcl = world
    rcl.feed("area_goal_received(a1, 2)", "area_goal_received(a2, 1)")
    rcl.feed("goal_cancelled(a1)")                   # its action is cancelled in the RCL
    assert rcl.cancelled == [f"cover({UAV},a1)"]
    assert list(rcl.open.values()) == [f"cover({UAV},a2)"]
    mark = len(rcl.log)
    rcl.feed("prioritychange(a2, 9)")                # asked again, at the new priority
    assert rcl.cancelled == [f"cover({UAV},a1)", f"cover({UAV},a2)"]
    assert rcl.since(mark) == [f"cover({UAV},a2)"] and rcl.priorities[-1][1] == 9
    assert agent.believes(f"task({UAV}, a2, 9)") and not agent.believes(f"task({UAV}, a2, 1)")
    mark = len(rcl.log)
    rcl.feed("prioritychange(a2, 9)")                # the same priority: nothing to do
    assert rcl.since(mark) == []
    assert agent.believes("cancelled_goal(a1)") and not agent.believes("done_goal(a1)")
    # the same goal may be sent again once it is over: open again, no ending believed
    rcl.finish(f"cover({UAV},a2)")
    agent.run_until_idle()
    rcl.feed("area_goal_received(a1, 2)")
    assert list(rcl.open.values()) == [f"cover({UAV},a1)"]
    assert not agent.believes("cancelled_goal(a1)") and agent.believes(f"task({UAV}, a1, 2)")


def test_battery_low_recharges_above_every_goal(world: tuple[Agent, Host]) -> None:
    agent, rcl = world
    rcl.feed("area_goal_received(a1, 2)")
    mark = len(rcl.log)
    rcl.feed("battery_low(uav1)")
    # the recharge takes the UAV's motion resource above any goal: the RCL suspends the
    # cover it flies, and resumes it after; the agent holds nothing itself
    assert rcl.since(mark) == ["recharge(uav1,recharge)"]
    assert rcl.priorities[-1] == ("recharge(uav1,recharge)", 1000)
    assert agent.believes("paused(uav1, battery)")
    rcl.feed("area_goal_received(a2, 9)")            # asked at once: another UAV may take it
    assert f"cover({UAV},a2)" in rcl.open.values()
    mark = len(rcl.log)
    agent.remove_percept("battery_low(uav1)")
    rcl.finish("recharge(uav1,recharge)")
    agent.run_until_idle()
    assert rcl.since(mark) == [] and not agent.believes("paused(uav1, _)")
    assert sorted(rcl.open.values()) == [f"cover({UAV},a1)", f"cover({UAV},a2)"]


def test_hotspot_water_and_teleop(world: tuple[Agent, Host]) -> None:
    agent, rcl = world
    rcl.feed("hotspot_detected(hs1, -35.36, 149.16)")
    assert list(rcl.open.values()) == [f"supply_water({UGV},hs1,-35.36,149.16,60)"]
    assert rcl.priorities[-1][1] == 10
    mark = len(rcl.log)
    rcl.feed("water_low(ugv1)")
    assert rcl.since(mark) == ["refill(ugv1,refill)"]
    rcl.finish("refill(ugv1,refill)")
    agent.run_until_idle()
    assert not agent.believes("paused(ugv1, _)")
    mark = len(rcl.log)
    rcl.feed("teleop(ugv1, on)")    # its actions suspended, whichever goals they serve
    assert rcl.since(mark) == ["rcl_goal_management(suspend,robot(ugv1))",
                               "teleop_mode(ugv1,on)"]
    rcl.finish("teleop_mode(ugv1,on)")
    mark = len(rcl.log)
    rcl.feed("hotspot_detected(hs2, -35.37, 149.17)")  # asked: the RCL gives it to ugv2
    assert rcl.since(mark) == ["supply_water(any([ugv,water],at(-35.37,149.17)),hs2,"
                               "-35.37,149.17,60)"]
    mark = len(rcl.log)
    agent.remove_percept("teleop(ugv1, on)")
    rcl.feed("teleop(ugv1, off)")
    assert rcl.since(mark) == ["teleop_mode(ugv1,off)"]
    mark = len(rcl.log)
    rcl.finish("teleop_mode(ugv1,off)")
    agent.run_until_idle()
    assert rcl.since(mark) == ["rcl_goal_management(resume,robot(ugv1))"]
    rcl.finish(f"supply_water({UGV},hs1")
    agent.run_until_idle()
    assert agent.believes("supplied(hs1)") and not agent.believes("supplied(hs2)")


def test_a_failed_goal_ends_and_an_unavailable_robot_holds_no_goal(
        world: tuple[Agent, Host]) -> None:
    agent, rcl = world
    rcl.feed("area_goal_received(a1, 2)", "area_goal_received(a2, 1)")
    rcl.finish(f"cover({UAV},a1)", ok=False)
    agent.run_until_idle()
    assert agent.believes("failed_goal(a1)") and not agent.believes("task(_, a1, _)")
    assert list(rcl.open.values()) == [f"cover({UAV},a2)"]
    # a robot lost: the RCL hands its tasks addressed to a role to others
    mark = len(rcl.log)
    rcl.feed("robot_unavailable(uav1)", "area_goal_received(a3, 9)")
    assert rcl.since(mark) == [f"cover({UAV},a3)"]
    rcl.feed("reassigned(cover(any([uav, camera]), a2), uav1, uav2)")
    agent.run_until_idle()
    assert not agent.believes("reassigned(_, _, _)")    # heard, and removed
    assert sorted(rcl.open.values()) == [f"cover({UAV},a2)", f"cover({UAV},a3)"]
    assert agent.believes(f"task({UAV}, a2, 1)") and not agent.believes("failed_goal(a2)")


def test_a_failed_recharge_holds_the_uav_until_the_battery_is_fixed(
        world: tuple[Agent, Host]) -> None:
    agent, rcl = world
    rcl.feed("area_goal_received(a1, 2)", "battery_low(uav1)")
    mark = len(rcl.log)
    rcl.finish("recharge(uav1,recharge)", ok=False)
    agent.run_until_idle()
    assert rcl.since(mark) == ["rcl_goal_management(suspend,robot(uav1))"]
    assert agent.believes("paused(uav1, battery)")       # nothing flies on a low battery
    mark = len(rcl.log)
    agent.remove_percept("battery_low(uav1)")            # swapped by hand
    agent.run_until_idle()
    assert rcl.since(mark) == ["rcl_goal_management(resume,robot(uav1))"]
    assert not agent.believes("paused(uav1, _)")


def test_the_operators_hold_suspends_every_robot_and_holds_new_goals(
        world: tuple[Agent, Host]) -> None:
    agent, rcl = world
    rcl.feed("area_goal_received(a1, 2)")
    mark = len(rcl.log)
    rcl.feed("hold_all")
    robots = ("uav1", "uav2", "uav3", "ugv1", "ugv2")
    assert sorted(rcl.since(mark)) == sorted(f"rcl_goal_management(suspend,robot({r}))"
                                             for r in robots)
    rcl.feed("area_goal_received(a2, 5)")             # held: not asked while all hold
    assert f"cover({UAV},a2)" not in rcl.log and agent.believes("on_hold(a2, 5, cover)")
    mark = len(rcl.log)
    agent.remove_percept("hold_all")
    agent.run_until_idle()
    assert sorted(rcl.since(mark)) == sorted(
        [f"rcl_goal_management(resume,robot({r}))" for r in robots] + [f"cover({UAV},a2)"])
    assert not agent.believes("on_hold(_, _, _)") and agent.believes(f"task({UAV}, a2, 5)")


def test_a_transient_failure_retries_the_goal_and_a_plain_one_ends_it(
        world: tuple[Agent, Host]) -> None:
    agent, rcl = world
    rcl.feed("area_goal_received(a1, 2)")
    for attempt in range(3):  # three transient failures: each time queued and begun again
        rcl.finish(f"cover({UAV},a1)", ok=False, error="transient" if attempt % 2 else "link_down")
        rcl.run_until(lambda: list(rcl.open.values()) == [f"cover({UAV},a1)"])
        assert agent.believes(f"tried(a1, {attempt + 1})")
    rcl.finish(f"cover({UAV},a1)", ok=False, error="transient")  # the fourth: given up
    agent.run_until_idle()
    assert agent.believes("failed_goal(a1)") and not rcl.open
    assert not agent.believes("area_goal_received(a1, 2)")  # forgotten: the goal ended

    rcl.feed("area_goal_received(a2, 1)")
    rcl.finish(f"cover({UAV},a2)", ok=False)  # no cause: action_failed, not retried
    agent.run_until_idle()
    assert agent.believes("failed_goal(a2)") and not rcl.open


def test_a_supplied_hotspot_is_consumed_so_a_restart_does_not_supply_it_again(
        world: tuple[Agent, Host]) -> None:
    agent, rcl = world
    rcl.feed("hotspot_detected(hs1, -35.36, 149.16)")
    rcl.finish(f"supply_water({UGV},hs1")
    agent.run_until_idle()
    assert agent.believes("supplied(hs1)")
    assert not agent.believes("hotspot_detected(hs1, -35.36, 149.16)")


def test_a_failed_switch_back_from_teleop_is_tried_again_until_it_succeeds(
        world: tuple[Agent, Host]) -> None:
    agent, rcl = world
    rcl.feed("teleop(ugv1, on)")
    rcl.finish("teleop_mode(ugv1,on)")
    agent.remove_percept("teleop(ugv1, on)")
    rcl.feed("teleop(ugv1, off)")
    rcl.finish("teleop_mode(ugv1,off)", ok=False, error="link_down")  # the link was lost
    agent.run_until_idle()
    assert agent.believes("paused(ugv1, teleop)")  # still teleoperated: not forgotten
    rcl.run_until(lambda: list(rcl.open.values()) == ["teleop_mode(ugv1,off)"])
    rcl.finish("teleop_mode(ugv1,off)")
    agent.run_until_idle()
    assert not agent.believes("paused(ugv1, teleop)")


def test_a_switch_retried_after_the_operator_changed_mind_sends_the_mode_wanted_now(
        world: tuple[Agent, Host]) -> None:
    """Chaos seed 6: the switch to teleop failed (link down) and was to be tried again in
    2 s; meanwhile the operator handed the robot back. The retry must not switch it to
    teleop again behind the agent's back (it believes it drives the robot)."""
    agent, rcl = world
    rcl.feed("teleop(ugv1, on)")
    rcl.finish("teleop_mode(ugv1,on)", ok=False, error="link_down")  # tried again in 2 s
    agent.run_until_idle()
    agent.remove_percept("teleop(ugv1, on)")
    rcl.feed("teleop(ugv1, off)")                       # the operator changed their mind
    rcl.finish("teleop_mode(ugv1,off)")
    agent.run_until_idle()
    assert not agent.believes("paused(ugv1, teleop)")
    mark = len(rcl.log)
    rcl.run_until(lambda: not agent.snapshot()["intentions"])  # the retry's turn, 2 s on
    assert rcl.since(mark) == [] and not rcl.open        # "on" is no longer wanted
    assert not agent.believes("paused(ugv1, teleop)")
    agent.remove_percept("teleop(ugv1, off)")           # and on again: followed at once
    rcl.feed("teleop(ugv1, on)")
    assert rcl.since(mark) == ["rcl_goal_management(suspend,robot(ugv1))",
                               "teleop_mode(ugv1,on)"]
    rcl.finish("teleop_mode(ugv1,on)")
    agent.run_until_idle()
    assert agent.believes("paused(ugv1, teleop)") and not rcl.open


def test_a_goal_cancelled_while_its_retry_waits_is_not_started_again(
        world: tuple[Agent, Host]) -> None:
    """A transient failure puts the goal back in the queue a second later; an operator's
    cancel in that second must end it, not be ignored as a cancel of an unknown goal (the
    robot would then work for a goal nobody wants). A priority change is kept."""
    agent, rcl = world
    rcl.feed("area_goal_received(a1, 2)", "area_goal_received(a2, 3)")
    rcl.finish(f"cover({UAV},a2)", ok=False, error="link_down")   # a2: again in 1 s
    agent.run_until_idle()
    assert list(rcl.open.values()) == [f"cover({UAV},a1)"]
    rcl.feed("goal_cancelled(a2)")                               # meanwhile: cancelled
    rcl.finish(f"cover({UAV},a1)", ok=False, error="transient")   # a1: again in 1 s
    agent.run_until_idle()
    rcl.feed("prioritychange(a1, 7)")                            # meanwhile: more urgent
    mark = len(rcl.log)
    rcl.run_until(lambda: bool(rcl.open))
    assert rcl.since(mark) == [f"cover({UAV},a1)"] and agent.believes(f"task({UAV}, a1, 7)")
    rcl.finish(f"cover({UAV},a1)")
    agent.run_until_idle()
    assert f"cover({UAV},a2)" not in rcl.since(mark) and not rcl.open
    assert rcl.priorities[-1] == (f"cover({UAV},a1)", 7)
    assert not agent.believes("task(_, a2, _)") and not agent.believes("tried(a2, _)")


def test_each_goal_counts_its_own_retries(world: tuple[Agent, Host]) -> None:
    """Chaos (15 faults, seed 1): hs4 was retried four times, "retry 1 of 3" each time.
    `-+tried(G, N)` replaces the first tried/2 of any goal (Jason's -+), so the UAV's
    retries erased the UGV's count, and max_tries bounded nothing."""
    agent, rcl = world
    rcl.feed("area_goal_received(a1, 2)", "hotspot_detected(hs1, -35.36, 149.16)")
    rcl.finish(f"cover({UAV},a1)", ok=False, error="link_down")
    rcl.finish(f"supply_water({UGV},hs1", ok=False, error="link_down")
    agent.run_until_idle()
    assert agent.believes("tried(a1, 1)") and agent.believes("tried(hs1, 1)")
    rcl.run_until(lambda: len(rcl.open) == 2)                 # both begun again
    rcl.finish(f"cover({UAV},a1)", ok=False, error="transient")
    agent.run_until_idle()
    assert agent.believes("tried(a1, 2)") and agent.believes("tried(hs1, 1)")
    assert not agent.believes("tried(a1, 1)")


def test_a_service_that_fails_for_a_transient_cause_is_tried_again(
        world: tuple[Agent, Host]) -> None:
    """Chaos (10 kills of the reasoner and the RCL, seed 1): the UGV's refill failed with
    link_down after an RCL restart and was given up: the UGV stayed paused for good, its
    hotspots waiting on a tank nobody filled. A plain failure still waits for a fix."""
    agent, rcl = world
    rcl.feed("hotspot_detected(hs1, -35.36, 149.16)", "water_low(ugv1)")
    rcl.finish("refill(ugv1,refill)", ok=False, error="link_down")
    agent.run_until_idle()
    assert agent.believes("paused(ugv1, water)")
    rcl.run_until(lambda: "refill(ugv1,refill)" in rcl.open.values())   # again, 1 s on
    rcl.finish("refill(ugv1,refill)")
    agent.run_until_idle()
    assert not agent.believes("paused(ugv1, water)")
    assert rcl.log.count("refill(ugv1,refill)") == 2 and not agent.believes("held(ugv1)")


def test_a_refused_teleop_switch_is_not_tried_again(world: tuple[Agent, Host]) -> None:
    """Issue 29: teleop of a robot the RCL does not have was retried every 2 s forever
    (500 such wishes: 250 rejected actions a second). A refusal ends the switch."""
    agent, rcl = world
    rcl.feed("teleop(ghost, on)")
    rcl.finish("teleop_mode(ghost,on)", ok=False, error="rejected")
    rcl.run_until(lambda: not agent.snapshot()["intentions"])  # a retry would be due in 2 s
    assert rcl.log.count("teleop_mode(ghost,on)") == 1 and not rcl.open


def retryable_failures(agent: Agent, rcl: ScriptedHost, action: str, error: str,
                       given_up: str) -> int:
    """Fail every try of `action` with `error` until the agent believes `given_up`; how
    many tries it made."""
    tries = 0
    while True:
        rcl.run_until(lambda: action in rcl.open.values() or agent.believes(given_up))
        if agent.believes(given_up):
            return tries
        rcl.finish(action, ok=False, error=error)
        tries += 1


def test_a_failing_teleop_switch_stops_at_its_budget_and_starts_again_with_the_robot(
        world: tuple[Agent, Host]) -> None:
    agent, rcl = world
    rcl.feed("teleop(ugv1, on)")
    assert retryable_failures(agent, rcl, "teleop_mode(ugv1,on)", "link_down",
                              "switch_given_up(ugv1, on)") == 30
    assert agent.believes("paused(ugv1, teleop)") and not rcl.open
    rcl.feed("robot_unavailable(ugv1)", "-robot_unavailable(ugv1)")   # the link is back
    rcl.finish("teleop_mode(ugv1,on)")                                # a new budget
    agent.run_until_idle()
    assert not agent.believes("switch_given_up(ugv1, _)") and not rcl.open


def test_a_failing_recharge_stops_at_its_budget_and_starts_again_with_the_robot(
        world: tuple[Agent, Host]) -> None:
    agent, rcl = world
    rcl.feed("area_goal_received(a1, 2)", "battery_low(uav1)")
    assert retryable_failures(agent, rcl, "recharge(uav1,recharge)", "transient",
                              "service_given_up(uav1, battery, recharge)") == 60
    assert agent.believes("paused(uav1, battery)")
    # its actions suspended (the cover the RCL gave it): nothing flies on a low battery
    assert rcl.log[-2:] == ["rcl_goal_management(suspend,robot(uav1))",
                            "give_up(service(uav1,recharge),budget_exhausted,transient)"]
    rcl.feed("robot_unavailable(uav1)", "-robot_unavailable(uav1)")
    mark = len(rcl.log)
    rcl.finish("recharge(uav1,recharge)")
    agent.run_until_idle()
    assert rcl.since(mark) == ["rcl_goal_management(resume,robot(uav1))"]
    assert not agent.believes("paused(uav1, _)")
