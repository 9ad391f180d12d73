"""The wildfire agent's decisions, on the real interpreter with a scripted RCL host.

Every environment action is recorded and stays open until the test completes it, as
the RCL would; `rcl_goal_management` is recorded and succeeds at once, as the
reasoner's host does. The whole system (real RCL, robots, broker) is exercised by
test_wildfire_scenario.py; this file covers the scheduling rules quickly.
"""

from __future__ import annotations

import itertools
from collections.abc import Hashable
from pathlib import Path

import pytest

from mrss.agentspeak import Agent, Struct, term_str

AGENT = Path(__file__).resolve().parent.parent / "agent.asl"


class ScriptedRcl:
    """Records actions; goal management succeeds at once, other actions wait for the test."""

    def __init__(self) -> None:
        self.agent: Agent | None = None
        self.log: list[str] = []
        self.open: dict[int, str] = {}
        self.cancelled: list[str] = []
        self._ids = itertools.count(1)

    def execute(self, action: Struct, intention_id: int) -> Hashable:
        handle = next(self._ids)
        text = term_str(Struct(action.functor, action.args))
        self.log.append(text)
        assert self.agent is not None
        if action.functor == "rcl_goal_management":
            self.agent.complete_action(handle, True)
        else:
            self.open[handle] = text
        return handle

    def cancel(self, handle: Hashable) -> None:
        self.cancelled.append(self.open.pop(int(str(handle))))

    def finish(self, prefix: str, ok: bool = True) -> None:
        """Complete the one open action whose text starts with `prefix`."""
        matches = [h for h, t in self.open.items() if t.startswith(prefix)]
        assert len(matches) == 1, f"{prefix!r} among open actions {self.open}"
        self.open.pop(matches[0])
        assert self.agent is not None
        self.agent.complete_action(matches[0], ok, None if ok else "robot said no")

    def since(self, mark: int) -> list[str]:
        return self.log[mark:]


@pytest.fixture()
def world() -> tuple[Agent, ScriptedRcl]:
    host = ScriptedRcl()
    agent = Agent.from_file(AGENT, host=host, name="wildfire", out=lambda line: None)
    host.agent = agent
    agent.run_until_idle()
    return agent, host


def feed(agent: Agent, *percepts: str) -> None:
    for p in percepts:
        agent.add_percept(p)
    agent.run_until_idle()


def test_area_goals_queue_by_priority_and_preempt(world: tuple[Agent, ScriptedRcl]) -> None:
    agent, rcl = world
    feed(agent, "area_goal_received(a1, 2)")
    assert list(rcl.open.values()) == ["cover(uav1,a1)"]
    feed(agent, "area_goal_received(a2, 1)")            # lower: waits in the queue
    assert list(rcl.open.values()) == ["cover(uav1,a1)"]
    mark = len(rcl.log)
    feed(agent, "area_goal_received(a3, 5)")            # higher: suspends a1, runs a3
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


def test_cancel_and_priority_change(world: tuple[Agent, ScriptedRcl]) -> None:
    agent, rcl = world
    feed(agent, "area_goal_received(a1, 2)", "area_goal_received(a2, 1)")
    feed(agent, "goal_cancelled(a1)")                   # running: its action is cancelled
    assert rcl.cancelled == ["cover(uav1,a1)"]
    assert list(rcl.open.values()) == ["cover(uav1,a2)"]
    feed(agent, "area_goal_received(a3, 1)")
    mark = len(rcl.log)
    feed(agent, "prioritychange(a3, 9)")                # now beats the running a2
    assert rcl.since(mark) == ["rcl_goal_management(suspend,a2)", "cover(uav1,a3)"]
    feed(agent, "goal_cancelled(a2)")                   # suspended: cancelled too
    assert rcl.cancelled == ["cover(uav1,a1)", "cover(uav1,a2)"]
    # the same goal may be sent again once it is over
    rcl.finish("cover(uav1,a3)")
    agent.run_until_idle()
    feed(agent, "area_goal_received(a1, 2)")
    assert list(rcl.open.values()) == ["cover(uav1,a1)"]


def test_battery_low_suspends_recharges_and_resumes(world: tuple[Agent, ScriptedRcl]) -> None:
    agent, rcl = world
    feed(agent, "area_goal_received(a1, 2)")
    mark = len(rcl.log)
    feed(agent, "battery_low(uav1)")
    assert rcl.since(mark) == ["rcl_goal_management(suspend,a1)", "recharge(uav1,recharge)"]
    feed(agent, "area_goal_received(a2, 9)")            # held while recharging
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


def test_hotspot_water_and_teleop(world: tuple[Agent, ScriptedRcl]) -> None:
    agent, rcl = world
    feed(agent, "hotspot_detected(hs1, -35.36, 149.16)")
    assert list(rcl.open.values()) == ["supply_water(ugv1,hs1,-35.36,149.16,60)"]
    mark = len(rcl.log)
    feed(agent, "water_low(ugv1)")
    assert rcl.since(mark) == ["rcl_goal_management(suspend,hs1)", "refill(ugv1,refill)"]
    mark = len(rcl.log)
    rcl.finish("refill(ugv1,refill)")
    agent.run_until_idle()
    assert rcl.since(mark) == ["rcl_goal_management(resume,hs1)"]
    mark = len(rcl.log)
    feed(agent, "teleop(ugv1, on)")
    assert rcl.since(mark) == ["rcl_goal_management(suspend,hs1)", "teleop_mode(ugv1,on)"]
    rcl.finish("teleop_mode(ugv1,on)")
    feed(agent, "hotspot_detected(hs2, -35.37, 149.17)")  # waits: the UGV is teleoperated
    assert not any(t.startswith("supply_water(ugv1,hs2") for t in rcl.log)
    mark = len(rcl.log)
    agent.remove_percept("teleop(ugv1, on)")
    feed(agent, "teleop(ugv1, off)")
    assert rcl.since(mark) == ["teleop_mode(ugv1,off)"]
    mark = len(rcl.log)
    rcl.finish("teleop_mode(ugv1,off)")
    agent.run_until_idle()
    assert rcl.since(mark) == ["rcl_goal_management(resume,hs1)"]
    rcl.finish("supply_water(ugv1,hs1")
    agent.run_until_idle()
    assert agent.believes("supplied(hs1)")
    assert list(rcl.open.values()) == ["supply_water(ugv1,hs2,-35.37,149.17,60)"]


def test_failed_goal_frees_the_robot(world: tuple[Agent, ScriptedRcl]) -> None:
    agent, rcl = world
    feed(agent, "area_goal_received(a1, 2)", "area_goal_received(a2, 1)")
    rcl.finish("cover(uav1,a1)", ok=False)
    agent.run_until_idle()
    assert agent.believes("failed_goal(a1)")
    assert list(rcl.open.values()) == ["cover(uav1,a2)"]
    feed(agent, "robot_unavailable(uav1)", "area_goal_received(a3, 9)")
    assert "cover(uav1,a3)" not in rcl.log                # held while unavailable
    mark = len(rcl.log)
    agent.remove_percept("robot_unavailable(uav1)")
    agent.run_until_idle()
    assert rcl.since(mark) == ["rcl_goal_management(suspend,a2)", "cover(uav1,a3)"]


def test_failed_recharge_holds_goals_until_the_battery_is_fixed(
        world: tuple[Agent, ScriptedRcl]) -> None:
    agent, rcl = world
    feed(agent, "area_goal_received(a1, 2)", "battery_low(uav1)")
    rcl.finish("recharge(uav1,recharge)", ok=False)
    agent.run_until_idle()
    feed(agent, "area_goal_received(a2, 9)")
    assert agent.believes("paused(uav1, battery)")
    assert not rcl.open                                  # nothing flies on a low battery
    mark = len(rcl.log)
    agent.remove_percept("battery_low(uav1)")            # swapped by hand
    agent.run_until_idle()
    assert rcl.since(mark) == ["cover(uav1,a2)"]
