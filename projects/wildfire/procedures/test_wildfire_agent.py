"""The wildfire agent's decisions, on the real interpreter with a scripted host.

mrss.api.testing.ScriptedHost records every environment action and keeps it open until
the test completes it, as the RCL would; `rcl_goal_management` is recorded and succeeds
at once, as the reasoner's host does. The whole system (real RCL, robots, broker) is
exercised by test_wildfire_scenario.py; this file covers the scheduling rules quickly.
"""

from __future__ import annotations

from pathlib import Path

import pytest

from mrss.api.testing import Agent, ScriptedHost

AGENT = Path(__file__).resolve().parent.parent / "agent.asl"


def running(rcl: ScriptedHost) -> list[str]:
    """The open actions the RCL would run: not those of a goal the agent suspended and did
    not resume (the RCL's rule: a suspended goal's later actions start suspended too)."""
    held: set[str] = set()
    for entry in rcl.log:
        if entry.startswith("rcl_goal_management("):
            command, goal = entry[len("rcl_goal_management("):-1].split(",")
            (held.add if command == "suspend" else held.discard)(goal)
    return [a for a in rcl.open.values() if a[:-1].split(",")[1] not in held]


@pytest.fixture()
def world() -> tuple[Agent, ScriptedHost]:
    host = ScriptedHost(virtual_time=True)  # the retries' .wait pauses are not waited out
    return host.load(AGENT, name="wildfire"), host


def test_area_goals_queue_by_priority_and_preempt(world: tuple[Agent, ScriptedHost]) -> None:
    agent, rcl = world
    rcl.feed("area_goal_received(a1, 2)")
    assert list(rcl.open.values()) == ["cover(uav1,a1)"]
    rcl.feed("area_goal_received(a2, 1)")            # lower: waits in the queue
    assert list(rcl.open.values()) == ["cover(uav1,a1)"]
    mark = len(rcl.log)
    rcl.feed("area_goal_received(a3, 5)")            # higher: suspends a1, runs a3
    assert rcl.since(mark) == ["rcl_goal_management(suspend,a1)", "cover(uav1,a3)"]
    mark = len(rcl.log)
    rcl.finish("cover(uav1,a3)")
    agent.run_until_idle()
    assert rcl.since(mark) == ["rcl_goal_management(resume,a1)"]   # a1 goes on first
    mark = len(rcl.log)
    rcl.finish("cover(uav1,a1)")
    agent.run_until_idle()
    assert rcl.since(mark) == ["cover(uav1,a2)"]
    rcl.finish("cover(uav1,a2)")
    agent.run_until_idle()
    assert not rcl.open and not agent.believes("task(_, _, _)")
    # how each goal ended is said, for the dashboard's mission panel
    assert all(agent.believes(f"done_goal({g})") for g in ("a1", "a2", "a3"))


def test_goals_perceived_together_start_one_task_per_robot(
        world: tuple[Agent, ScriptedHost]) -> None:
    """A restarted reasoner perceives every durable goal at once (so does a burst from the
    operator): the robot still runs one goal, the best, and the others wait their turn."""
    agent, rcl = world
    rcl.feed("area_goal_received(a1, 2)", "area_goal_received(a2, 3)",
             "area_goal_received(a3, 4)", "area_goal_received(a4, 1)",
             "area_goal_received(a5, 4)")
    assert rcl.log.count("cover(uav1,a3)") == 1        # not once per goal perceived
    assert running(rcl) == ["cover(uav1,a3)"]
    assert agent.believes("task(uav1, a3, 4)")
    for goal in ("a3", "a5", "a2", "a1", "a4"):        # priority, then the oldest
        assert running(rcl) == [f"cover(uav1,{goal})"]
        rcl.finish(f"cover(uav1,{goal})")
        agent.run_until_idle()
    assert all(rcl.log.count(f"cover(uav1,{g})") == 1 for g in ("a1", "a2", "a3", "a4", "a5"))
    assert not rcl.open and not agent.believes("task(_, _, _)")


def test_cancel_and_priority_change(world: tuple[Agent, ScriptedHost]) -> None:
    agent, rcl = world
    rcl.feed("area_goal_received(a1, 2)", "area_goal_received(a2, 1)")
    rcl.feed("goal_cancelled(a1)")                   # running: its action is cancelled
    assert rcl.cancelled == ["cover(uav1,a1)"]
    assert list(rcl.open.values()) == ["cover(uav1,a2)"]
    rcl.feed("area_goal_received(a3, 1)")
    mark = len(rcl.log)
    rcl.feed("prioritychange(a3, 9)")                # now beats the running a2
    assert rcl.since(mark) == ["rcl_goal_management(suspend,a2)", "cover(uav1,a3)"]
    rcl.feed("goal_cancelled(a2)")                   # suspended: cancelled too
    assert rcl.cancelled == ["cover(uav1,a1)", "cover(uav1,a2)"]
    assert agent.believes("cancelled_goal(a1)") and agent.believes("cancelled_goal(a2)")
    assert not agent.believes("done_goal(a1)")
    # the same goal may be sent again once it is over: open again, no ending believed
    rcl.finish("cover(uav1,a3)")
    agent.run_until_idle()
    rcl.feed("area_goal_received(a1, 2)")
    assert list(rcl.open.values()) == ["cover(uav1,a1)"]
    assert not agent.believes("cancelled_goal(a1)") and agent.believes("task(uav1, a1, 2)")


def test_battery_low_suspends_recharges_and_resumes(world: tuple[Agent, ScriptedHost]) -> None:
    agent, rcl = world
    rcl.feed("area_goal_received(a1, 2)")
    mark = len(rcl.log)
    rcl.feed("battery_low(uav1)")
    assert rcl.since(mark) == ["rcl_goal_management(suspend,a1)", "recharge(uav1,recharge)"]
    rcl.feed("area_goal_received(a2, 9)")            # held while recharging
    assert "cover(uav1,a2)" not in rcl.log
    mark = len(rcl.log)
    agent.remove_percept("battery_low(uav1)")
    rcl.finish("recharge(uav1,recharge)")
    agent.run_until_idle()
    assert rcl.since(mark) == ["cover(uav1,a2)"]        # the best goal first
    mark = len(rcl.log)
    rcl.finish("cover(uav1,a2)")
    agent.run_until_idle()
    assert rcl.since(mark) == ["rcl_goal_management(resume,a1)"]


def test_hotspot_water_and_teleop(world: tuple[Agent, ScriptedHost]) -> None:
    agent, rcl = world
    rcl.feed("hotspot_detected(hs1, -35.36, 149.16)")
    assert list(rcl.open.values()) == ["supply_water(ugv1,hs1,-35.36,149.16,60)"]
    mark = len(rcl.log)
    rcl.feed("water_low(ugv1)")
    assert rcl.since(mark) == ["rcl_goal_management(suspend,hs1)", "refill(ugv1,refill)"]
    mark = len(rcl.log)
    rcl.finish("refill(ugv1,refill)")
    agent.run_until_idle()
    assert rcl.since(mark) == ["rcl_goal_management(resume,hs1)"]
    mark = len(rcl.log)
    rcl.feed("teleop(ugv1, on)")
    assert rcl.since(mark) == ["rcl_goal_management(suspend,hs1)", "teleop_mode(ugv1,on)"]
    rcl.finish("teleop_mode(ugv1,on)")
    rcl.feed("hotspot_detected(hs2, -35.37, 149.17)")  # waits: the UGV is teleoperated
    assert not any(t.startswith("supply_water(ugv1,hs2") for t in rcl.log)
    mark = len(rcl.log)
    agent.remove_percept("teleop(ugv1, on)")
    rcl.feed("teleop(ugv1, off)")
    assert rcl.since(mark) == ["teleop_mode(ugv1,off)"]
    mark = len(rcl.log)
    rcl.finish("teleop_mode(ugv1,off)")
    agent.run_until_idle()
    assert rcl.since(mark) == ["rcl_goal_management(resume,hs1)"]
    rcl.finish("supply_water(ugv1,hs1")
    agent.run_until_idle()
    assert agent.believes("supplied(hs1)")
    assert list(rcl.open.values()) == ["supply_water(ugv1,hs2,-35.37,149.17,60)"]


def test_failed_goal_frees_the_robot(world: tuple[Agent, ScriptedHost]) -> None:
    agent, rcl = world
    rcl.feed("area_goal_received(a1, 2)", "area_goal_received(a2, 1)")
    rcl.finish("cover(uav1,a1)", ok=False)
    agent.run_until_idle()
    assert agent.believes("failed_goal(a1)")
    assert list(rcl.open.values()) == ["cover(uav1,a2)"]
    rcl.feed("robot_unavailable(uav1)", "area_goal_received(a3, 9)")
    assert "cover(uav1,a3)" not in rcl.log                # held while unavailable
    mark = len(rcl.log)
    agent.remove_percept("robot_unavailable(uav1)")
    agent.run_until_idle()
    assert rcl.since(mark) == ["rcl_goal_management(suspend,a2)", "cover(uav1,a3)"]


def test_failed_recharge_holds_goals_until_the_battery_is_fixed(
        world: tuple[Agent, ScriptedHost]) -> None:
    agent, rcl = world
    rcl.feed("area_goal_received(a1, 2)", "battery_low(uav1)")
    rcl.finish("recharge(uav1,recharge)", ok=False)
    agent.run_until_idle()
    rcl.feed("area_goal_received(a2, 9)")
    assert agent.believes("paused(uav1, battery)")
    assert not running(rcl)                              # nothing flies on a low battery
    mark = len(rcl.log)
    agent.remove_percept("battery_low(uav1)")            # swapped by hand
    agent.run_until_idle()
    assert rcl.since(mark) == ["cover(uav1,a2)"]


def test_a_transient_failure_retries_the_goal_and_a_plain_one_ends_it(
        world: tuple[Agent, ScriptedHost]) -> None:
    agent, rcl = world
    rcl.feed("area_goal_received(a1, 2)")
    for attempt in range(3):  # three transient failures: each time queued and begun again
        rcl.finish("cover(uav1,a1)", ok=False, error="transient" if attempt % 2 else "link_down")
        rcl.run_until(lambda: list(rcl.open.values()) == ["cover(uav1,a1)"])
        assert agent.believes(f"tried(a1, {attempt + 1})")
    rcl.finish("cover(uav1,a1)", ok=False, error="transient")  # the fourth: given up
    agent.run_until_idle()
    assert agent.believes("failed_goal(a1)") and not rcl.open
    assert not agent.believes("area_goal_received(a1, 2)")  # forgotten: the goal ended

    rcl.feed("area_goal_received(a2, 1)")
    rcl.finish("cover(uav1,a2)", ok=False)  # no cause: action_failed, not retried
    agent.run_until_idle()
    assert agent.believes("failed_goal(a2)") and not rcl.open


def test_a_supplied_hotspot_is_consumed_so_a_restart_does_not_supply_it_again(
        world: tuple[Agent, ScriptedHost]) -> None:
    agent, rcl = world
    rcl.feed("hotspot_detected(hs1, -35.36, 149.16)")
    rcl.finish("supply_water(ugv1,hs1")
    agent.run_until_idle()
    assert agent.believes("supplied(hs1)")
    assert not agent.believes("hotspot_detected(hs1, -35.36, 149.16)")


def test_a_failed_switch_back_from_teleop_is_tried_again_until_it_succeeds(
        world: tuple[Agent, ScriptedHost]) -> None:
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
        world: tuple[Agent, ScriptedHost]) -> None:
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
    assert rcl.since(mark) == ["teleop_mode(ugv1,on)"]
    rcl.finish("teleop_mode(ugv1,on)")
    agent.run_until_idle()
    assert agent.believes("paused(ugv1, teleop)") and not rcl.open


def test_a_goal_cancelled_while_its_retry_waits_is_not_started_again(
        world: tuple[Agent, ScriptedHost]) -> None:
    """A transient failure puts the goal back in the queue a second later; an operator's
    cancel in that second must end it, not be ignored as a cancel of an unknown goal (the
    robot would then work for a goal nobody wants). A priority change is kept."""
    agent, rcl = world
    rcl.feed("area_goal_received(a1, 2)", "area_goal_received(a2, 3)")
    rcl.finish("cover(uav1,a2)", ok=False, error="link_down")   # a2: again in 1 s
    agent.run_until_idle()
    assert list(rcl.open.values()) == ["cover(uav1,a1)"]
    rcl.feed("goal_cancelled(a2)")                               # meanwhile: cancelled
    rcl.finish("cover(uav1,a1)", ok=False, error="transient")   # a1: again in 1 s
    agent.run_until_idle()
    rcl.feed("prioritychange(a1, 7)")                            # meanwhile: more urgent
    mark = len(rcl.log)
    rcl.run_until(lambda: bool(rcl.open))
    assert rcl.since(mark) == ["cover(uav1,a1)"] and agent.believes("task(uav1, a1, 7)")
    rcl.finish("cover(uav1,a1)")
    agent.run_until_idle()
    assert "cover(uav1,a2)" not in rcl.since(mark) and not rcl.open
    assert not agent.believes("queued(_, a2, _, _)") and not agent.believes("tried(a2, _)")


def test_each_goal_counts_its_own_retries(world: tuple[Agent, ScriptedHost]) -> None:
    """Chaos (15 faults, seed 1): hs4 was retried four times, "retry 1 of 3" each time.
    `-+tried(G, N)` replaces the first tried/2 of any goal (Jason's -+), so the UAV's
    retries erased the UGV's count, and max_tries bounded nothing."""
    agent, rcl = world
    rcl.feed("area_goal_received(a1, 2)", "hotspot_detected(hs1, -35.36, 149.16)")
    rcl.finish("cover(uav1,a1)", ok=False, error="link_down")
    rcl.finish("supply_water(ugv1,hs1", ok=False, error="link_down")
    agent.run_until_idle()
    assert agent.believes("tried(a1, 1)") and agent.believes("tried(hs1, 1)")
    rcl.run_until(lambda: len(rcl.open) == 2)                 # both begun again
    rcl.finish("cover(uav1,a1)", ok=False, error="transient")
    agent.run_until_idle()
    assert agent.believes("tried(a1, 2)") and agent.believes("tried(hs1, 1)")
    assert not agent.believes("tried(a1, 1)")


def test_a_service_that_fails_for_a_transient_cause_is_tried_again(
        world: tuple[Agent, ScriptedHost]) -> None:
    """Chaos (10 kills of the reasoner and the RCL, seed 1): the UGV's refill failed with
    link_down after an RCL restart and was given up: the UGV stayed paused for good, its
    hotspots waiting on a tank nobody filled. A plain failure still waits for a fix."""
    agent, rcl = world
    rcl.feed("hotspot_detected(hs1, -35.36, 149.16)", "water_low(ugv1)")
    rcl.finish("refill(ugv1,refill)", ok=False, error="link_down")
    agent.run_until_idle()
    assert agent.believes("paused(ugv1, water)")
    rcl.run_until(lambda: "refill(ugv1,refill)" in rcl.open.values())   # again, 1 s on
    mark = len(rcl.log)
    rcl.finish("refill(ugv1,refill)")
    agent.run_until_idle()
    assert rcl.since(mark) == ["rcl_goal_management(resume,hs1)"]
    assert not agent.believes("paused(ugv1, water)")


def test_a_refused_teleop_switch_is_not_tried_again(world: tuple[Agent, ScriptedHost]) -> None:
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
        world: tuple[Agent, ScriptedHost]) -> None:
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
        world: tuple[Agent, ScriptedHost]) -> None:
    agent, rcl = world
    rcl.feed("area_goal_received(a1, 2)", "battery_low(uav1)")
    assert retryable_failures(agent, rcl, "recharge(uav1,recharge)", "transient",
                              "service_given_up(uav1, battery, recharge)") == 60
    assert agent.believes("paused(uav1, battery)") and not running(rcl)  # goals wait
    rcl.feed("robot_unavailable(uav1)", "-robot_unavailable(uav1)")
    mark = len(rcl.log)
    rcl.finish("recharge(uav1,recharge)")
    agent.run_until_idle()
    assert rcl.since(mark) == ["rcl_goal_management(resume,a1)"]
    assert not agent.believes("paused(uav1, _)")
