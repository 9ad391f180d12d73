"""Issue: the mission survives faults, end to end through `mrss supervise` (real processes).

- an action that ends while the bus proxy is down still releases its latch (its terminal
  status is asked for again by the reasoner's reconciliation);
- a reasoner SIGKILLed mid-action: the new incarnation re-derives the goal from its
  percept ledger and adopts the running action (same uuid, never cancelled or redone);
- teleop off reaching a restarted reasoner is not dropped: the standing teleop percept
  was asserted again, so the switch back happens.
"""

from __future__ import annotations

import json
import os
import signal
import sqlite3

import pytest

from mrss.testing import wait_until
from tests.e2e.system import System, beliefs, waiting_on_actions

pytestmark = pytest.mark.slow


def _journal(system: System, uuid: str) -> tuple[str, int, dict[str, object]]:
    """(state, requester incarnation, progress) of an action in the RCL's journal file."""
    path = system.run_dir / "rcl-journal.sqlite3"
    with sqlite3.connect(str(path), timeout=5) as db:
        row = db.execute("SELECT state, requester_inc, progress FROM actions WHERE uuid=?",
                         (uuid,)).fetchone()
    assert row is not None, f"{uuid} is not in the journal"
    return str(row[0]), int(row[1]), json.loads(row[2])


def test_an_action_ending_while_the_bus_proxy_is_down_still_releases_its_latch(
        system: System) -> None:
    system.percept("gated_goal(ugv1, g1)")
    uuid = system.request("gated", "g1").uuid
    system.wait_state(uuid, "running")

    # the proxy dies and, with the root supervisor held, stays down while the action ends
    root = system.proc.pid
    proxy = system.tree_pid("bus")
    incarnation = system.incarnation("rcl")
    os.kill(root, signal.SIGSTOP)
    try:
        os.kill(proxy, signal.SIGKILL)
        (system.run_dir / "g1.gate").touch()
        wait_until(lambda: _journal(system, uuid)[0] == "succeeded", timeout=10,
                   message="the journal's terminal commit")
    finally:
        os.kill(root, signal.SIGCONT)
    # the status went into the void; the reasoner reconciles and its plan goes on
    snap = system.wait_mind(lambda s: beliefs(s, "gated_done(g1)"), timeout=15,
                            message="the latch released after the blackout")
    assert not waiting_on_actions(snap) and not beliefs(snap, "gated_failed(")
    assert system.incarnation("rcl") == incarnation  # the RCL itself never restarted


def test_a_killed_reasoner_is_replaced_by_one_that_adopts_its_running_actions(
        system: System) -> None:
    rcl_pid = system.pid("rcl")
    system.percept("patrol_goal(ugv1, g1, 120)")  # 6 s of waypoints
    system.percept("patrol_goal(ugv2, g2, 120)")
    uuids = {g: system.request("patrol", g).uuid for g in ("g1", "g2")}
    for uuid in uuids.values():
        system.wait_state(uuid, "running")
    wait_until(lambda: all(int(_journal(system, u)[2].get("waypoint", 0)) >= 3  # type: ignore[call-overload]
                           for u in uuids.values()), timeout=10, message="under way")

    system.signal("reasoner", signal.SIGKILL)
    wait_until(lambda: system.incarnation("reasoner") == 2, timeout=15,
               message="reasoner incarnation 2 heartbeating")
    # incarnation 2 re-derives both goals from its ledger and adopts the two patrols
    wait_until(lambda: all(_journal(system, u)[1] == 2 for u in uuids.values()), timeout=15,
               message="both patrols adopted by incarnation 2")
    snap = system.wait_mind(lambda s: len(beliefs(s, "patrolled(")) == 2, timeout=30,
                            message="both patrols concluded by incarnation 2")
    assert not beliefs(snap, "patrol_failed(") and not waiting_on_actions(snap)
    for goal, uuid in uuids.items():
        state, _, progress = _journal(system, uuid)
        assert state == "succeeded", goal
        assert progress["starts"] == [0], goal  # one run from waypoint 0: never restarted
        assert "cancelled" not in [s.state for _, s in system.statuses(uuid)]
    # the RCL itself never stopped; no new patrol was requested for the same goals
    assert system.pid("rcl") == rcl_pid and system.incarnation("rcl") == 1
    assert sorted(r.uuid for r in system.requests("patrol")) == sorted(uuids.values())


def test_teleop_off_reaching_a_restarted_reasoner_switches_the_robot_back(
        system: System) -> None:
    system.percept("patrol_goal(ugv1, g1, 80)")
    uuid = system.request("patrol", "g1").uuid
    system.wait_state(uuid, "running")
    system.percept("teleop(ugv1, on)")
    system.wait_state(uuid, "suspended")

    system.signal("reasoner", signal.SIGKILL)
    wait_until(lambda: system.incarnation("reasoner") == 2, timeout=15,
               message="reasoner incarnation 2 heartbeating")
    system.wait_mind(lambda s: beliefs(s, "teleop(ugv1,on)"), timeout=10,
                     message="the standing teleop percept asserted again")
    system.percept("teleop(ugv1, on)", op="remove")
    system.percept("teleop(ugv1, off)")
    # the patrol is resumed and completes for incarnation 2
    system.wait_state(uuid, "running", timeout=15)
    system.wait_state(uuid, "succeeded", timeout=30)
    snap = system.wait_mind(lambda s: beliefs(s, "patrolled(g1)"), timeout=15,
                            message="the patrol concluded after teleop off")
    assert not waiting_on_actions(snap)
