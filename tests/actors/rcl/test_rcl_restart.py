"""A restarted RCL (or robot actor) reloads the journal: nothing open is forgotten."""

from __future__ import annotations

import sqlite3
from typing import Any

from mrss.actors.rcl.core import RclCore
from mrss.actors.rcl.journal import ActionJournal
from mrss.messages import ActionControl, ActionRequest
from mrss.testing import wait_until
from tests.actors.rcl.rcl_sim import RclEnv, SimRobot, request_fields


def test_rcl_restart_resumes_or_fails_every_open_action(rcl_env: RclEnv) -> None:
    core = rcl_env.start()
    ugv, uav = rcl_env.robots["ugv1"], rcl_env.robots["uav1"]
    ugv.auto = True
    core.submit_fields(request_fields("done", "patrol", "ugv1", "g0", ["p0"]))
    wait_until(rcl_env.statuses.reached("done", "succeeded"))
    ugv.auto = False
    core.submit_fields(request_fields("run", "patrol", "ugv1", "g1", ["p1", "p2", "p3"]))
    ugv.arrive()
    wait_until(lambda: ugv.is_moving_to("p2"))
    core.submit_fields(request_fields("held", "patrol", "uav1", "g2", ["q1"]))
    wait_until(lambda: uav.is_moving_to("q1"))
    core.control(ActionControl("suspend", "held"))
    wait_until(rcl_env.statuses.reached("held", "suspended"))
    core.submit_fields(request_fields("gone", "patrol", "ugv2", "g3", ["r1"]))
    wait_until(rcl_env.statuses.reached("gone", "running"))

    rcl_env.stop()  # the RCL goes away with three actions open
    before = len(rcl_env.statuses.items)
    rcl_env.layer.refined.clear()
    core = rcl_env.start(robots={"ugv1": ugv, "uav1": uav})  # ugv2 no longer configured

    wait_until(lambda: ugv.is_moving_to("p2"), message="'run' resumed from waypoint 2")
    assert rcl_env.layer.refined[0].uuid == "run"
    assert rcl_env.layer.refined[0].progress == {"waypoint": 1}
    wait_until(rcl_env.statuses.reached("gone", "failed"))
    wait_until(lambda: len(rcl_env.statuses.items) >= before + 3)
    after = {s.uuid: s for s in rcl_env.statuses.items[before:]}
    assert after["run"].state == "running" and "RCL restart" in after["run"].reason
    assert after["held"].state == "suspended" and "RCL restart" in after["held"].reason
    assert "'ugv2' is not configured" in after["gone"].reason
    assert "done" not in after
    assert {u: s.value for u, s in core.observers.active().items()} == {
        "run": "running", "held": "suspended"}

    # still idempotent across the restart, and still controllable
    core.submit(ActionRequest(uuid="done", name="patrol", args=["ugv1", "g0", ["p0"]]))
    core.control(ActionControl("resume", "held"))
    wait_until(lambda: uav.is_moving_to("q1"))
    ugv.arrive(2)
    uav.arrive()
    wait_until(rcl_env.statuses.reached("run", "succeeded"))
    wait_until(rcl_env.statuses.reached("held", "succeeded"))
    assert ugv.visited == ["p0", "p1", "p2", "p3"]


def test_project_may_refuse_to_resume_after_restart(rcl_env: RclEnv) -> None:
    core = rcl_env.start()
    core.submit_fields(request_fields("a1", "patrol", "ugv1", "g1", ["p1"]))
    wait_until(rcl_env.statuses.reached("a1", "running"))
    rcl_env.stop()
    rcl_env.layer.resume_after_restart = lambda action: False  # type: ignore[method-assign]
    rcl_env.start()
    wait_until(rcl_env.statuses.reached("a1", "failed"))
    last = rcl_env.statuses.last("a1")
    assert last is not None and "does not resume 'patrol'" in last.reason


def test_teleop_survives_a_restart(rcl_env: RclEnv) -> None:
    core = rcl_env.start()
    core.submit_fields(request_fields("a1", "patrol", "ugv1", "g1", ["p1"]))
    wait_until(rcl_env.statuses.reached("a1", "running"))
    core.availability.set_teleop("ugv1", True)
    wait_until(rcl_env.statuses.reached("a1", "suspended"))
    rcl_env.stop()
    core = rcl_env.start()
    wait_until(lambda: len(rcl_env.statuses.states("a1")) == 4)
    assert rcl_env.statuses.states("a1")[-1] == "suspended"
    core.availability.set_teleop("ugv1", False)
    wait_until(lambda: rcl_env.robots["ugv1"].is_moving_to("p1"))
    rcl_env.robots["ugv1"].arrive()
    wait_until(rcl_env.statuses.reached("a1", "succeeded"))


class _DiskHiccup(ActionJournal):
    """A journal whose next progress write fails like a real I/O error."""

    fail_next = False

    def save_progress(self, uuid: str, progress: dict[str, Any]) -> None:
        if self.fail_next:
            self.fail_next = False
            raise sqlite3.OperationalError("disk I/O error")
        super().save_progress(uuid, progress)


def _progress(journal: ActionJournal, uuid: str) -> object:
    entry = journal.get(uuid)
    return entry.action.progress if entry else None


def test_crashed_robot_actor_is_restarted_from_the_journal(rcl_env: RclEnv) -> None:
    journal = _DiskHiccup(rcl_env.journal_path)
    ugv = rcl_env.robots["ugv1"]
    core = RclCore(rcl_env.layer, journal, rcl_env.statuses, {"ugv1": ugv})
    core.start()
    try:
        core.submit_fields(request_fields("a1", "patrol", "ugv1", "g1", ["p1", "p2", "p3"]))
        ugv.arrive()
        wait_until(lambda: ugv.is_moving_to("p2"))
        wait_until(lambda: _progress(journal, "a1") == {"waypoint": 1})
        journal.fail_next = True
        ugv.arrive()  # reaching p2 records progress: the write fails, the robot actor dies
        wait_until(lambda: any("restart of robot actor ugv1" in s.reason
                               for s in rcl_env.statuses.of("a1")))
        assert any(getattr(m, "event", "") == "restart" for m in rcl_env.statuses.others)
        assert rcl_env.layer.refined[-1].progress == {"waypoint": 1}
        wait_until(lambda: ugv.is_moving_to("p2"))  # resumed from the journaled waypoint
        ugv.arrive(2)
        wait_until(rcl_env.statuses.reached("a1", "succeeded"))
        # the restarted actor serves new actions too
        core.submit_fields(request_fields("a2", "noop", "ugv1", "g2"))
        wait_until(rcl_env.statuses.reached("a2", "succeeded"))
    finally:
        ugv.halt()
        core.stop()
        journal.close()


def test_robot_crashing_too_often_is_quarantined_and_released(rcl_env: RclEnv) -> None:
    class AlwaysFails(ActionJournal):
        def save_progress(self, uuid: str, progress: dict[str, Any]) -> None:
            raise sqlite3.OperationalError("disk I/O error")

    journal = AlwaysFails(rcl_env.journal_path)
    ugv = SimRobot("ugv1", auto=True)
    core = RclCore(rcl_env.layer, journal, rcl_env.statuses, {"ugv1": ugv},
                   max_robot_restarts=2, probation=3.0)  # a2 comes within it
    core.start()
    try:
        core.submit_fields(request_fields("a1", "patrol", "ugv1", "g1", ["p1", "p2"]))
        wait_until(rcl_env.statuses.reached("a1", "failed"))
        last = rcl_env.statuses.last("a1")
        assert last is not None and "quarantined" in last.reason
        events = [getattr(m, "event", "") for m in rcl_env.statuses.others]
        assert events.count("restart") == 2 and "quarantine" in events
        core.submit_fields(request_fields("a2", "noop", "ugv1", "g2"))
        wait_until(rcl_env.statuses.reached("a2", "failed"))
        last = rcl_env.statuses.last("a2")
        assert last is not None and "ugv1 unavailable: quarantined" in last.reason
        wait_until(lambda: any(getattr(m, "event", "") == "release"
                               for m in rcl_env.statuses.others), timeout=30,
                   message="released")
        core.submit_fields(request_fields("a3", "noop", "ugv1", "g3"))
        wait_until(rcl_env.statuses.reached("a3", "succeeded"))
    finally:
        core.stop()
        journal.close()


def test_links_closing_while_the_rcl_stops_fail_nothing(rcl_env: RclEnv) -> None:
    """Chaos campaigns (every clean stop): RclService closes the links after the core has
    stopped, and a closing link reports "link closed". That is no news of the robot: it
    must not fail the open actions the next start resumes (nor try to journal it)."""
    core = rcl_env.start()
    ugv = rcl_env.robots["ugv1"]
    core.submit_fields(request_fields("run", "patrol", "ugv1", "g1", ["p1", "p2"]))
    wait_until(lambda: ugv.is_moving_to("p1"))
    core.stop()
    assert core.availability.link_state("ugv1", False, "link closed") == []
    rcl_env.stop()
    core = rcl_env.start(robots={"ugv1": ugv, "uav1": rcl_env.robots["uav1"]})
    wait_until(lambda: ugv.is_moving_to("p1"), message="'run' resumed")
    assert rcl_env.statuses.states("run")[-1] == "running"
    assert {u: s.value for u, s in core.observers.active().items()} == {"run": "running"}
    assert core.availability.link_state("ugv1", False, "no heartbeat") == ["run"]  # a live one does
    wait_until(rcl_env.statuses.reached("run", "failed"))
