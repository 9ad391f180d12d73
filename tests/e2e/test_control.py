"""Issue 5, end to end: teleop through the agent's goal management, and resource
pre-emption by priority, with the resumed actions continuing from their progress."""

from __future__ import annotations

import json
import sqlite3

import pytest

from mrss.messages import ActionControl, ActionStatus, Envelope
from mrss.testing import wait_until
from tests.e2e.system import System, beliefs, waiting_on_actions

pytestmark = pytest.mark.slow


def _journaled_waypoint(system: System, uuid: str) -> int:
    with sqlite3.connect(str(system.run_dir / "rcl-journal.sqlite3"), timeout=5) as db:
        row = db.execute("SELECT progress FROM actions WHERE uuid=?", (uuid,)).fetchone()
    return int(json.loads(row[0]).get("waypoint", 0)) if row else 0


def _states(system: System, uuid: str) -> list[str]:
    """The transitions of an action (statuses sent again by reconciliation left out)."""
    return [s.state for _, s in system.statuses(uuid)]


def _index(system: System, uuid: str, state: str) -> int:
    """Position of `uuid`'s first `state` status among every status seen."""
    stream = [e for e in system.envelopes(ActionStatus)
              if isinstance(e.body, ActionStatus) and not e.body.repeat]
    return next(i for i, e in enumerate(stream) if _is(e, uuid, state))


def _is(env: Envelope, uuid: str, state: str) -> bool:
    body = env.body
    return isinstance(body, ActionStatus) and body.uuid == uuid and body.state == state


def test_teleop_percept_suspends_every_action_of_the_robot_and_off_resumes_from_progress(
        system: System) -> None:
    system.percept("patrol_goal(ugv1, t1, 60)")
    system.percept("patrol_goal(ugv1, t2, 60)")
    system.percept("patrol_goal(ugv2, t3, 60)")
    uuids = {g: system.request("patrol", g).uuid for g in ("t1", "t2", "t3")}
    wait_until(lambda: all(_journaled_waypoint(system, u) >= 3 for u in uuids.values()),
               timeout=10, message="every patrol past waypoint 3")

    system.percept("teleop(ugv1, on)")  # the agent: rcl_goal_management(suspend, robot(ugv1))
    suspended = {g: system.wait_state(uuids[g], "suspended") for g in ("t1", "t2")}
    for status in suspended.values():
        assert status.robot == "ugv1" and status.reason == "suspended by the agent"
        assert int(status.progress["waypoint"]) >= 3  # type: ignore[arg-type]
    # the operator has ugv1: its intentions wait, ugv2's patrol goes on undisturbed
    snap = system.wait_mind(lambda s: beliefs(s, "teleop(ugv1,on)"), message="teleop on")
    assert len(waiting_on_actions(snap)) >= 2 and not beliefs(snap, "patrol_failed(")
    kept = {g: _journaled_waypoint(system, uuids[g]) for g in ("t1", "t2")}
    assert kept == {g: int(s.progress["waypoint"]) for g, s in suspended.items()}  # type: ignore[arg-type]

    system.percept("teleop(ugv1, off)")  # rcl_goal_management(resume, robot(ugv1))
    for goal in ("t1", "t2"):
        uuid = uuids[goal]
        resumed = wait_until(lambda u=uuid: [s for _, s in system.statuses(u)  # type: ignore[misc]
                                             if s.state == "running"][1:],
                             message=f"{goal} resumed")[0]
        assert resumed.reason == "resumed by the agent"
        assert resumed.progress["waypoint"] == kept[goal]  # nothing lost while suspended
        done = system.wait_state(uuid, "succeeded", timeout=15)
        assert done.progress["starts"] == [0, kept[goal]]  # the second run went on from there
        assert done.progress["waypoint"] == 60
        assert _states(system, uuid) == ["pending", "running", "suspended", "running",
                                         "succeeded"]
    assert _states(system, uuids["t3"]) == ["pending", "running", "succeeded"]
    snap = system.wait_mind(lambda s: len(beliefs(s, "patrolled(")) == 3, timeout=15,
                            message="all three patrols done")
    assert not snap.intentions


def test_higher_priority_preempts_the_resource_and_the_preempted_action_resumes_after(
        system: System) -> None:
    system.percept("survey_goal(uav1, low, 1, 40)")
    low = system.request("survey", "low")
    assert low.priority == 1
    wait_until(lambda: _journaled_waypoint(system, low.uuid) >= 3, timeout=10,
               message="the low-priority survey under way")

    system.percept("survey_goal(uav2, high, 5, 10)")
    high = system.request("survey", "high")
    assert high.priority == 5
    preempted = system.wait_state(low.uuid, "suspended")
    assert preempted.reason == ("pre-empted: airspace is needed by a higher-priority "
                                "action")
    done = system.wait_state(high.uuid, "succeeded", timeout=10)
    assert done.progress == {"starts": [0], "waypoint": 10}

    final = system.wait_state(low.uuid, "succeeded", timeout=15)
    assert _states(system, low.uuid) == ["pending", "running", "suspended", "running",
                                         "succeeded"]
    # the airspace went to the high-priority survey, and back to the low one once free
    # (the resource is free when the high skill ends, which may beat its action's status)
    assert _index(system, low.uuid, "suspended") < _index(system, high.uuid, "succeeded")
    resumed = [s for _, s in system.statuses(low.uuid) if s.state == "running"][1]
    assert resumed.reason == "resumed: its resource is free"
    kept = int(preempted.progress["waypoint"])  # type: ignore[arg-type]
    assert resumed.progress["waypoint"] == kept  # it did not move while pre-empted
    assert final.progress == {"starts": [0, kept], "waypoint": 40}

    # the agent never saw the pre-emption: both intentions simply completed
    snap = system.wait_mind(lambda s: len(beliefs(s, "surveyed(")) == 2,
                            message="both surveys done in the agent")
    assert not beliefs(snap, "survey_failed(") and not snap.intentions


def test_a_freed_resource_goes_to_the_preempted_action_before_a_lower_waiter(
        system: System) -> None:
    """Issue 11: A (5) holds the airspace, B (9) pre-empts it, C (1) waits; when B ends,
    A (pre-empted, higher) gets the airspace back before C (waiting, lower)."""
    system.percept("survey_goal(uav1, a, 5, 40)")
    a = system.request("survey", "a")
    wait_until(lambda: _journaled_waypoint(system, a.uuid) >= 3, timeout=10,
               message="A under way")
    system.percept("survey_goal(uav2, b, 9, 100000)")  # B holds until the operator cancels it
    b = system.request("survey", "b")
    system.wait_state(a.uuid, "suspended")
    wait_until(lambda: _journaled_waypoint(system, b.uuid) >= 1, timeout=10,
               message="B holds the airspace")
    system.percept("survey_goal(ugv1, c, 1, 10)")
    c = system.request("survey", "c")
    wait_until(lambda: f"action {c.uuid} waits for airspace" in system.log_text(), timeout=10,
               message="C waits for the airspace")

    system.publish(ActionControl(command="cancel", target="b", target_kind="goal"))
    system.wait_state(b.uuid, "cancelled")
    done_a = system.wait_state(a.uuid, "succeeded", timeout=20)
    system.wait_state(c.uuid, "succeeded", timeout=20)
    assert _states(system, a.uuid) == ["pending", "running", "suspended", "running",
                                       "succeeded"]
    resumed = [s for _, s in system.statuses(a.uuid) if s.state == "running"][1]
    assert resumed.reason == "resumed: its resource is free"
    assert done_a.progress["waypoint"] == 40
    assert _index(system, a.uuid, "succeeded") < _index(system, c.uuid, "succeeded")
    assert _journaled_waypoint(system, c.uuid) == 10
    assert "suspended" not in _states(system, c.uuid)  # C waited, RUNNING, never pre-empted


def test_an_operator_cancel_reaches_the_agent_as_error_cancelled(system: System) -> None:
    system.percept("gated_goal(ugv3, gx)")
    uuid = system.request("gated", "gx").uuid
    system.wait_state(uuid, "running")
    system.publish(ActionControl(command="cancel", target="gx", target_kind="goal"))
    status = system.wait_state(uuid, "cancelled")
    assert status.cause == "cancelled" and status.reason == "cancelled by the operator"
    snap = system.wait_mind(lambda s: beliefs(s, "gated_failed(gx,cancelled)"), timeout=10,
                            message="the agent's -!gated saw error(cancelled)")
    assert not waiting_on_actions(snap)
