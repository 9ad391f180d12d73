"""An action's life through the RCL in-process: request, skills, statuses, end."""

from __future__ import annotations

import logging
from pathlib import Path

import pytest

from mrss.actors.rcl.journal import ActionJournal
from mrss.api import Skill
from mrss.messages import ActionRequest, FailureCause, SupEvent
from mrss.testing import wait_until
from tests.actors.rcl_sim import Crash, RclEnv, request_fields


def test_action_runs_its_skills_and_succeeds(rcl_env: RclEnv) -> None:
    rcl_env.robots["ugv1"].auto = True
    core = rcl_env.start()
    core.submit_fields(request_fields("a1", "patrol", "ugv1", "g1", ["p1", "p2", "p3"]))
    wait_until(rcl_env.statuses.reached("a1", "succeeded"), message="a1 succeeded")
    assert rcl_env.statuses.states("a1") == ["pending", "running", "succeeded"]
    assert rcl_env.robots["ugv1"].visited == ["p1", "p2", "p3"]
    last = rcl_env.statuses.last("a1")
    assert last is not None and last.progress == {"waypoint": 3} and last.robot == "ugv1"
    assert [a.uuid for a in rcl_env.layer.ended] == ["a1"]
    assert rcl_env.layer.ended[0].state.value == "succeeded"
    assert core.observers.active() == {}


def test_every_status_is_journaled_before_it_is_published(rcl_env: RclEnv) -> None:
    rcl_env.robots["ugv1"].auto = True
    core = rcl_env.start()
    core.submit_fields(request_fields("a1", "patrol", "ugv1", "g1", ["p1"]))
    wait_until(rcl_env.statuses.reached("a1", "succeeded"))
    assert rcl_env.statuses.check_failures == []
    assert rcl_env.journal is not None
    journaled = [s.value for s, _ in rcl_env.journal.transitions("a1")]
    assert journaled == rcl_env.statuses.states("a1")


def test_skill_that_raises_fails_its_action_with_the_message(rcl_env: RclEnv) -> None:
    rcl_env.robots["ugv1"].auto = True
    core = rcl_env.start()
    core.submit_fields(request_fields("c1", "crash", "ugv1", "g1", "motor overheated"))
    wait_until(rcl_env.statuses.reached("c1", "failed"))
    last = rcl_env.statuses.last("c1")
    assert last is not None and "RuntimeError: motor overheated" in last.reason
    # the robot actor survived: the same robot still runs the next action
    core.submit_fields(request_fields("a2", "patrol", "ugv1", "g2", ["p1"]))
    wait_until(rcl_env.statuses.reached("a2", "succeeded"))


def test_crashing_skill_is_restarted_per_its_policy(rcl_env: RclEnv) -> None:
    core = rcl_env.start()
    core.submit_fields(request_fields("f1", "flaky", "ugv1", "g1"))
    wait_until(rcl_env.statuses.reached("f1", "succeeded"))
    assert rcl_env.statuses.states("f1") == ["pending", "running", "succeeded"]
    restarts = [m for m in rcl_env.statuses.others
                if isinstance(m, SupEvent) and m.detail.get("action") == "f1"]
    assert [(e.event, e.child, e.supervisor, e.count) for e in restarts] == [
        ("restart", "Crash", "robots/ugv1", 1), ("restart", "Crash", "robots/ugv1", 2)]
    assert restarts[0].reason == "Crash raised RuntimeError: flaky motor"


def test_skill_crashing_past_its_intensity_escalates_and_fails_its_action(
        rcl_env: RclEnv) -> None:
    rcl_env.layer.recipes["jammed"] = lambda a: [Crash("jammed", restarts=2)]
    rcl_env.robots["ugv1"].auto = True
    core = rcl_env.start()
    core.submit_fields(request_fields("j1", "jammed", "ugv1", "g1"))
    wait_until(rcl_env.statuses.reached("j1", "failed"))
    events = [(m.event, m.count) for m in rcl_env.statuses.others
              if isinstance(m, SupEvent) and m.detail.get("action") == "j1"]
    assert events == [("restart", 1), ("restart", 2), ("escalate", 2)]
    escalation = [m for m in rcl_env.statuses.others
                  if isinstance(m, SupEvent) and m.event == "escalate"][0]
    assert "more than 2 restarts of Crash in 60s" in str(escalation.detail["note"])
    last = rcl_env.statuses.last("j1")
    assert last is not None and last.reason == "Crash raised RuntimeError: jammed"
    # the escalation goes on to the robot's supervisor: the robot actor restarts
    robot_restart = wait_until(lambda: [
        m for m in rcl_env.statuses.others if isinstance(m, SupEvent)
        and m.event == "restart" and m.child == "ugv1"], message="the robot actor's restart")
    assert robot_restart[0].supervisor == "robots"
    assert robot_restart[0].reason.startswith("escalated: skill 0 of action j1 escalated")
    core.submit_fields(request_fields("a2", "patrol", "ugv1", "g2", ["p1"]))
    wait_until(rcl_env.statuses.reached("a2", "succeeded"))


def test_a_robot_whose_skills_keep_escalating_is_quarantined(rcl_env: RclEnv) -> None:
    rcl_env.layer.recipes["jammed"] = lambda a: [Crash("jammed", restarts=1)]
    rcl_env.robots["ugv2"].auto = True
    core = rcl_env.start(max_robot_restarts=1)
    for n in (1, 2):  # one robot restart is allowed, the second escalation is one too many
        core.submit_fields(request_fields(f"j{n}", "jammed", "ugv1", f"g{n}"))
        wait_until(rcl_env.statuses.reached(f"j{n}", "failed"))
        wait_until(lambda n=n: len([m for m in rcl_env.statuses.others
                                    if isinstance(m, SupEvent) and m.child == "ugv1"
                                    and m.event in ("restart", "quarantine")]) >= n,
                   message=f"escalation {n} handled by the robot supervisor")
    quarantine = [m for m in rcl_env.statuses.others
                  if isinstance(m, SupEvent) and m.event == "quarantine" and m.child == "ugv1"]
    assert len(quarantine) == 1 and quarantine[0].reason.startswith("escalated:")
    core.submit_fields(request_fields("a3", "patrol", "ugv1", "g3", ["p1"]))
    wait_until(rcl_env.statuses.reached("a3", "failed"))
    last = rcl_env.statuses.last("a3")
    assert last is not None and last.cause == FailureCause.QUARANTINED
    core.submit_fields(request_fields("a4", "patrol", "ugv2", "g4", ["p1"]))  # the others run
    wait_until(rcl_env.statuses.reached("a4", "succeeded"))


def test_skill_returning_failure_fails_the_action_with_its_reason(rcl_env: RclEnv) -> None:
    core = rcl_env.start()
    core.submit_fields(request_fields("r1", "refuse", "ugv1", "g1"))
    wait_until(rcl_env.statuses.reached("r1", "failed"))
    last = rcl_env.statuses.last("r1")
    assert last is not None and last.reason == "target out of reach"


def test_action_without_skills_succeeds(rcl_env: RclEnv) -> None:
    core = rcl_env.start()
    core.submit_fields(request_fields("n1", "noop", "uav1", "g1"))
    wait_until(rcl_env.statuses.reached("n1", "succeeded"))


@pytest.mark.parametrize(("fields", "reason"), [
    ({"uuid": "m1", "name": "patrol", "args": "ugv1"}, "field 'args' has type str"),
    ({"uuid": "m1", "name": "patrol", "args": [], "priority": "high"}, "'priority'"),
    ({"uuid": "m1", "name": "", "args": ["ugv1", "g"]}, "field 'name' is empty"),
    ({"uuid": "m1", "name": "patrol", "args": []}, "no robot id"),
    ({"uuid": "m1", "name": "patrol", "args": [7, "g"]}, "no robot id"),
    ({"uuid": "m1", "name": "patrol", "args": ["ugv9", "g"]}, "unknown robot 'ugv9'"),
    ({"uuid": "m1", "name": "patrol", "args": ["ugv1"], "colour": 1}, "unknown field"),
    ({"uuid": "m1", "name": "dance", "args": ["ugv1", "g"]}, "no recipe for action 'dance'"),
])
def test_malformed_request_is_failed_with_a_logged_reason(
    rcl_env: RclEnv, caplog: pytest.LogCaptureFixture, fields: dict[str, object], reason: str,
) -> None:
    core = rcl_env.start()
    with caplog.at_level(logging.WARNING, logger="mrss.rcl"):
        core.submit_fields(fields)
        wait_until(rcl_env.statuses.reached("m1", "failed"))
    last = rcl_env.statuses.last("m1")
    assert last is not None and reason in last.reason
    assert any(reason in r.getMessage() for r in caplog.records), caplog.text
    assert rcl_env.robots["ugv1"].visited == []


def test_requests_for_robots_that_do_not_exist_fail_each_and_are_logged_once(
    rcl_env: RclEnv, caplog: pytest.LogCaptureFixture,
) -> None:
    """Issue 29: each rejected request was a WARNING line (21,206 in 90 s of a teleop
    flood). Each still fails with its reason; the log tells of them once per interval."""
    core = rcl_env.start()
    with caplog.at_level(logging.WARNING, logger="mrss.rcl"):
        for n in range(100):
            core.submit_fields(request_fields(f"g{n}", "patrol", f"ghost{n}", "g", []))
        wait_until(lambda: all(rcl_env.statuses.reached(f"g{n}", "failed")()
                               for n in range(100)), message="every request failed")
    for n in range(100):
        last = rcl_env.statuses.last(f"g{n}")
        assert last is not None and f"unknown robot 'ghost{n}'" in last.reason
    assert core.rejections.stats() == {"-: unknown robot": 100}
    lines = [r.getMessage() for r in caplog.records if "unknown robot" in r.getMessage()]
    assert len(lines) == 1 and "refused action request from -: unknown robot" in lines[0]


def test_request_without_uuid_is_dropped_and_logged(
    rcl_env: RclEnv, caplog: pytest.LogCaptureFixture,
) -> None:
    core = rcl_env.start()
    with caplog.at_level(logging.WARNING, logger="mrss.rcl"):
        core.submit_fields({"name": "patrol", "args": ["ugv1", "g"]})
    assert "without a uuid" in caplog.text
    assert rcl_env.statuses.items == []


def test_duplicate_uuid_is_not_run_twice(rcl_env: RclEnv) -> None:
    rcl_env.robots["ugv1"].auto = True
    core = rcl_env.start()
    core.submit(ActionRequest(uuid="d1", name="patrol", args=["ugv1", "g1", ["p1"]]))
    wait_until(rcl_env.statuses.reached("d1", "succeeded"))
    core.submit(ActionRequest(uuid="d1", name="patrol", args=["ugv1", "g1", ["p1"]]))
    # the duplicate only re-sends the final status: no new run, no new transition
    wait_until(lambda: len(rcl_env.statuses.of("d1")) == 4)
    assert rcl_env.statuses.states("d1") == ["pending", "running", "succeeded", "succeeded"]
    assert rcl_env.robots["ugv1"].visited == ["p1"]
    assert [a.uuid for a in rcl_env.layer.refined] == ["d1"]


def test_duplicate_of_a_running_action_does_not_start_it_again(rcl_env: RclEnv) -> None:
    core = rcl_env.start()
    robot = rcl_env.robots["ugv1"]
    core.submit_fields(request_fields("d2", "patrol", "ugv1", "g1", ["p1"]))
    wait_until(lambda: robot.is_moving_to("p1"))
    core.submit_fields(request_fields("d2", "patrol", "ugv1", "g1", ["p1"]))
    robot.arrive()
    wait_until(rcl_env.statuses.reached("d2", "succeeded"))
    assert len(rcl_env.layer.refined) == 1 and robot.visited == ["p1"]


def test_unavailable_robot_rejects_new_actions(rcl_env: RclEnv) -> None:
    core = rcl_env.start()
    core.availability.set_available("uav1", False, "link down")
    core.submit_fields(request_fields("u1", "noop", "uav1", "g1"))
    wait_until(rcl_env.statuses.reached("u1", "failed"))
    last = rcl_env.statuses.last("u1")
    assert last is not None and "uav1 unavailable: link down" in last.reason
    core.availability.set_available("uav1", True)
    core.submit_fields(request_fields("u2", "noop", "uav1", "g1"))
    wait_until(rcl_env.statuses.reached("u2", "succeeded"))


class _JournalProbe(Skill):
    """Reads the journal through a connection of its own first thing in `start()`."""

    def __init__(self, journal_path: Path, seen: dict[str, str | None]) -> None:
        self.journal_path, self.seen = journal_path, seen

    def start(self) -> None:
        reader = ActionJournal(self.journal_path)
        try:
            entry = reader.get(self.action.uuid)
            self.seen[self.action.uuid] = None if entry is None else entry.action.state.value
        finally:
            reader.close()

    def run(self) -> bool:
        return True


def test_skills_start_after_the_commit_and_pending_is_published_before_running(
        rcl_env: RclEnv) -> None:
    # The robot actor is told right after the journal commit, while PENDING goes out:
    # its skills may start first, but never before the action is journaled (a SIGKILL
    # then restores it), and its RUNNING is never published before PENDING.
    seen: dict[str, str | None] = {}
    rcl_env.layer.recipes["probe"] = lambda a: [_JournalProbe(rcl_env.journal_path, seen)]
    core = rcl_env.start()
    uuids = [f"p{i}" for i in range(30)]
    for i, uuid in enumerate(uuids):
        core.submit_fields(request_fields(uuid, "probe", ("ugv1", "ugv2", "uav1")[i % 3], "g"))
    for uuid in uuids:
        wait_until(rcl_env.statuses.reached(uuid, "succeeded"), message=f"{uuid} succeeded")
    assert {uuid: seen.get(uuid) in ("pending", "running") for uuid in uuids} == \
        {uuid: True for uuid in uuids}
    assert {uuid: rcl_env.statuses.states(uuid) for uuid in uuids} == \
        {uuid: ["pending", "running", "succeeded"] for uuid in uuids}
    assert rcl_env.statuses.check_failures == []
