"""Issue 5, end to end through real processes: the Listing-1 flow, a failing skill, and
malformed action messages (bus proxy, RCL and reasoner under `mrss supervise`)."""

from __future__ import annotations

import re

import msgpack
import pytest

from mrss.bus import ReliableSender, wire
from mrss.messages import ActionRequest, MindSnapshot, SupEvent
from mrss.testing import wait_until
from tests.e2e.system import System, beliefs, waiting_on_actions

pytestmark = pytest.mark.slow


def test_listing1_percept_goal_action_skills_status_and_the_plan_continues(
        system: System) -> None:
    system.percept("area_goal_received(g1, 2)")

    cover = system.request("cover", "g1")  # percept -> +!coverarea -> cover(...) action
    assert (cover.args, cover.robot, cover.priority) == (["uav1", "g1", 6], "uav1", 2)
    running = system.wait_state(cover.uuid, "running")
    assert running.robot == "uav1"
    done = system.wait_state(cover.uuid, "succeeded", timeout=10)
    assert done.progress == {"starts": [0], "waypoint": 6}  # the skill visited all six
    states = [s.state for _, s in system.statuses(cover.uuid)]
    assert states == ["pending", "running", "succeeded"]

    # the latch released: the plan went on to its next action, which the RCL ran too
    report = system.request("report", "g1")
    assert report.args == ["uav1", "g1"]
    system.wait_state(report.uuid, "succeeded")

    snap = system.wait_mind(lambda s: beliefs(s, "covered(g1)") and not s.intentions,
                            message="covered(g1) believed, intention finished")
    assert "available(uav1)[source(self)]" in snap.beliefs  # the plan ran to its end
    assert not beliefs(snap, "currenttask(")
    assert not beliefs(snap, "cover_failed(")


def test_a_raising_skill_fails_its_action_and_the_plan_failure_handler_sees_why(
        system: System) -> None:
    system.percept("probe_goal(ugv3, p1)")
    probe = system.request("probe", "p1")
    failed = system.wait_state(probe.uuid, "failed")
    assert failed.reason == "Jam raised RuntimeError: gearbox jammed on ugv3"
    # restarted under the supervision policy, each restart a sup event, then escalated
    def escalations() -> list[SupEvent]:
        return [e for e in system.sup_events("Jam")
                if e.detail.get("action") == probe.uuid and e.event == "escalate"]
    wait_until(escalations, message="sup.escalate of the skill")
    skill = escalations()
    events = [(e.event, e.count, e.supervisor) for e in system.sup_events("Jam")
              if e.detail.get("action") == probe.uuid]
    assert events == [("restart", 1, "robots/ugv3"), ("restart", 2, "robots/ugv3"),
                      ("escalate", 2, "robots/ugv3")]
    assert "more than 2 restarts of Jam" in str(skill[0].detail["note"])
    # ... on to the robot's supervisor: the robot actor fails and is restarted
    (robot,) = wait_until(lambda: [e for e in system.sup_events("ugv3") if e.event == "restart"],
                          message="the robot actor's restart after the escalation")
    assert robot.supervisor == "robots" and robot.reason.startswith("escalated: ")

    snap = system.wait_mind(lambda s: beliefs(s, "probe_failed(p1"),
                            message="-!probe handled the failure")
    (handled,) = beliefs(snap, "probe_failed(p1")
    assert "gearbox jammed on ugv3" in handled
    assert not beliefs(snap, "probed(p1)")
    assert not waiting_on_actions(snap)
    assert [e.event for e in system.sup_events("rcl")] in ([], ["start"])  # no restart


def _raw_reliable(system: System, session: bytes, seq: int, payload: bytes) -> None:
    """A frame on the reliable action channel, as a buggy or hostile peer could send."""
    system.pub.send_frames((wire.data_topic("action"), b"action.request", payload,
                            wire.pack_header(session, seq, seq)))


def test_malformed_action_messages_are_rejected_with_a_logged_reason_and_the_rcl_serves_on(
        system: System) -> None:
    rcl_pid = system.pid("rcl")
    tx = ReliableSender(system.endpoints, src="tester", channel="action")  # unsupervised: inc 0
    try:
        # well-formed messages the RCL must refuse: each gets a FAILED status and a log line
        tx.send(ActionRequest(uuid="bad-robot", name="patrol", args=["tank9", "g", 3]))
        tx.send(ActionRequest(uuid="no-robot", name="patrol", args=[]))
        tx.send(ActionRequest(uuid="no-recipe", name="dance", args=["ugv1", "g"]))
        assert system.wait_state("bad-robot", "failed").reason.startswith(
            "rejected: unknown robot 'tank9'")
        assert "no robot id" in system.wait_state("no-robot", "failed").reason
        assert system.wait_state("no-recipe", "failed").reason.endswith(
            "no recipe for action 'dance'")
    finally:
        tx.close()
    # malformed messages: not msgpack, a body of the wrong type, a wrong field type
    session = b"\x07" * 16
    _raw_reliable(system, session, 1, b"\xc1 not msgpack")
    _raw_reliable(system, session, 2, msgpack.packb(
        {"v": 1, "id": "m2", "ts": 0.0, "src": "x", "inc": 1, "kind": "action.request",
         "body": {"uuid": "typed", "name": "patrol", "args": "ugv1"}}))
    _raw_reliable(system, session, 3, msgpack.packb(["not", "an", "envelope"]))

    wait_until(lambda: system.log_text().count("dropped malformed message") >= 3, timeout=10,
               message="three malformed messages logged")
    log = system.log_text()
    # Refusals are logged once per kind and interval (mrss/edge/rejections.py), the first
    # of each kind with its request.
    assert re.search(r"refused action request from \S+: unknown robot \(bad-robot: unknown "
                     r"robot 'tank9'", log), log
    assert re.search(r"refused action request from \S+: .*\(no-robot: ", log), log
    dropped = "reliable receiver 'action': dropped malformed message on topic 'action.request'"
    assert f"{dropped}: not msgpack" in log
    assert f"{dropped}: action.request: field 'args' has type str" in log
    assert f"{dropped}: envelope is not a map" in log
    assert system.statuses("typed") == []  # dropped by the bus: never reached the RCL

    # and the RCL serves on, in the same process
    system.percept("probe_goal(ugv2, p2)")
    system.wait_state(system.request("probe", "p2").uuid, "failed")
    system.percept("patrol_goal(ugv1, g9, 2)")
    system.wait_state(system.request("patrol", "g9").uuid, "succeeded")
    assert system.pid("rcl") == rcl_pid
    assert all(e.event == "start" for e in system.sup_events("rcl"))
    assert isinstance(system.mind(), MindSnapshot)
