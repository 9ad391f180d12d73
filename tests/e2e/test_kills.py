"""Issue 5, end to end: SIGKILL the RCL or the reasoner mid-action, SIGSTOP the RCL past
the reasoner's lease. Nothing waits forever, no robot works for a dead intention."""

from __future__ import annotations

import json
import shutil
import signal
import sqlite3
from collections.abc import Iterator
from pathlib import Path

import pytest

from mrss.messages import ActionStatus
from mrss.testing import wait_until
from tests.e2e.system import PROJECTS, System, beliefs, running_system, waiting_on_actions

pytestmark = pytest.mark.slow

ROBOTS = ["ugv1", "ugv2", "ugv3", "ugv4", "ugv5"]
WAYPOINTS = 40  # 0.05 s each: a 2 s patrol


def _start_patrols(system: System, count: int = WAYPOINTS) -> dict[str, str]:
    """One patrol per robot; returns goal -> action uuid once every one is under way."""
    for i, robot in enumerate(ROBOTS, 1):
        system.percept(f"patrol_goal({robot}, g{i}, {count})")
    uuids = {f"g{i}": system.request("patrol", f"g{i}").uuid for i in range(1, 6)}
    for uuid in uuids.values():
        system.wait_state(uuid, "running")
    # progress is journaled, not published: watch it in the journal's file
    wait_until(lambda: all(_journaled_waypoint(system, u) >= 3 for u in uuids.values()),
               timeout=10, message="every patrol past waypoint 3")
    return uuids


def _latest(system: System, uuid: str) -> ActionStatus | None:
    found = system.statuses(uuid)
    return found[-1][1] if found else None


def _journaled_waypoint(system: System, uuid: str) -> int:
    path = system.run_dir / "rcl-journal.sqlite3"
    with sqlite3.connect(str(path), timeout=5) as db:
        row = db.execute("SELECT progress FROM actions WHERE uuid=?", (uuid,)).fetchone()
    return int(json.loads(row[0]).get("waypoint", 0)) if row else 0


@pytest.fixture()
def long_lease_system(tmp_path: Path) -> Iterator[System]:
    """The e2e project with a 600 s lease: whether an RCL restart beats the lease is a
    matter of the machine's speed, and this test is about resuming, not the lease
    (test_rcl_silent_past_the_lease_... is)."""
    projects = tmp_path / "projects"
    shutil.copytree(PROJECTS / "e2e", projects / "e2e")
    toml = projects / "e2e" / "project.toml"
    text = toml.read_text()
    assert "\nlease = 2.0\n" in text
    toml.write_text(text.replace("\nlease = 2.0\n", "\nlease = 600.0\n"))
    with running_system(projects) as system:
        yield system


def test_sigkilled_rcl_resumes_every_running_action_from_its_journal_and_no_intention_waits(
        long_lease_system: System) -> None:
    system = long_lease_system
    uuids = _start_patrols(system)
    old_pid = system.signal("rcl", signal.SIGKILL)
    kept = {g: _journaled_waypoint(system, u) for g, u in uuids.items()}

    # the root supervisor restarts the RCL; incarnation 2 re-announces each action
    wait_until(lambda: system.incarnation("rcl") == 2, timeout=15, message="RCL restarted")
    assert system.pid("rcl", inc=2) != old_pid
    for goal, uuid in uuids.items():
        def after_restart(u: str = uuid) -> list[ActionStatus]:
            return [s for inc, s in system.statuses(u) if inc == 2]
        first = wait_until(after_restart, timeout=15, message=f"{goal} after the restart")[0]
        # resumed from its journaled progress, not started again
        assert first.state == "running" and "resumed after an RCL restart" in first.reason, \
            (goal, first)
        assert int(first.progress["waypoint"]) >= kept[goal]  # type: ignore[arg-type]

    # and every intention continues to its end: none hangs, none is failed
    snap = system.wait_mind(lambda s: len(beliefs(s, "patrolled(")) == 5, timeout=60,
                            message="all five patrols concluded in the agent")
    assert not beliefs(snap, "patrol_failed(")
    assert not waiting_on_actions(snap)
    assert not snap.intentions
    for goal, uuid in uuids.items():
        final = _latest(system, uuid)
        assert final is not None and final.state == "succeeded", (goal, final)
        starts = final.progress["starts"]
        assert isinstance(starts, list) and starts[0] == 0 and len(starts) == 2
        assert starts[1] >= kept[goal]  # the second run started where the first stopped


def test_sigkilled_reasoner_rcl_keeps_running_and_cancels_the_orphans_nobody_adopts(
        system: System) -> None:
    rcl_pid = system.pid("rcl")
    system.percept(f"patrol_goal(ugv1, g1, {WAYPOINTS * 3})")
    system.percept(f"patrol_goal(ugv2, g2, {WAYPOINTS * 3})")
    orphans = [system.request("patrol", g).uuid for g in ("g1", "g2")]
    for uuid in orphans:
        system.wait_state(uuid, "running")
    # the operator withdraws both goals (the agent lets the patrols run): a new
    # incarnation has nothing to re-derive them from, so nobody adopts the patrols
    system.percept(f"patrol_goal(ugv1, g1, {WAYPOINTS * 3})", op="remove")
    system.percept(f"patrol_goal(ugv2, g2, {WAYPOINTS * 3})", op="remove")
    system.wait_mind(lambda s: not beliefs(s, "patrol_goal("), message="goals withdrawn")

    system.signal("reasoner", signal.SIGKILL)
    wait_until(lambda: system.incarnation("reasoner") == 2, timeout=15,
               message="reasoner incarnation 2 heartbeating")
    for uuid in orphans:
        cancelled = system.wait_state(uuid, "cancelled", "failed", "succeeded", timeout=10)
        assert cancelled.state == "cancelled"
        assert cancelled.reason == "orphaned: reasoner incarnation 1 is gone"
    # the RCL itself never stopped: same process, incarnation 1, no exit event
    assert system.pid("rcl") == rcl_pid and system.incarnation("rcl") == 1
    assert [e.event for e in system.sup_events("rcl")] in ([], ["start"])
    # the new incarnation's own heartbeat may overtake the root's sup.start on the bus
    wait_until(lambda: [e.event for e in system.sup_events("reasoner")][-3:]
               == ["exit", "restart", "start"], timeout=10,
               message="sup exit, restart, start of the reasoner")

    # the new incarnation starts from a clean mind and works normally
    snap = system.wait_mind(lambda s: not s.intentions, message="fresh mind")
    assert not beliefs(snap, "patrol_goal(")
    system.percept("patrol_goal(ugv1, g3, 2)")
    system.wait_state(system.request("patrol", "g3").uuid, "succeeded")


def test_rcl_silent_past_the_lease_fails_waiting_actions_then_recovers(system: System) -> None:
    system.percept(f"patrol_goal(ugv1, g1, {WAYPOINTS * 2})")
    system.percept(f"patrol_goal(ugv2, g2, {WAYPOINTS * 2})")
    uuids = [system.request("patrol", g).uuid for g in ("g1", "g2")]
    for uuid in uuids:
        system.wait_state(uuid, "running")

    system.signal("rcl", signal.SIGSTOP)
    try:
        snap = system.wait_mind(lambda s: len(beliefs(s, "patrol_failed(")) == 2, timeout=10,
                                message="the lease failed both waiting patrols")
        for failed in beliefs(snap, "patrol_failed("):
            assert "no word of the action from the RCL" in failed and "lease 2.0s" in failed
        assert not waiting_on_actions(snap)
        assert all(system.last_state(u) == "running" for u in uuids)  # the RCL never said
    finally:
        system.signal("rcl", signal.SIGCONT)

    # the RCL comes back (same process): the abandoned actions are cancelled there, so
    # no robot keeps working for a failed intention, and new work is served
    for uuid in uuids:
        assert system.wait_state(uuid, "cancelled", "succeeded", "failed",
                                 timeout=10).state == "cancelled"
    assert system.incarnation("rcl") == 1
    system.percept("patrol_goal(ugv3, g3, 2)")
    system.wait_state(system.request("patrol", "g3").uuid, "succeeded")
    snap = system.wait_mind(lambda s: beliefs(s, "patrolled(g3)"), message="g3 patrolled")
    assert not snap.intentions


def test_rcl_hung_past_the_supervisor_limit_is_restarted_and_its_abandoned_actions_cancelled(
        system: System) -> None:
    system.percept(f"patrol_goal(ugv1, g1, {WAYPOINTS * 4})")
    uuid = system.request("patrol", "g1").uuid
    system.wait_state(uuid, "running")
    hung = system.signal("rcl", signal.SIGSTOP)  # never SIGCONTed: the supervisor acts

    system.wait_mind(lambda s: beliefs(s, "patrol_failed(g1"), timeout=10,
                     message="the lease failed the waiting patrol")
    # 24 missed 0.25 s heartbeats later the root supervisor kills and restarts the RCL;
    # incarnation 2 resumes the journaled action, the reasoner sees it open and cancels it
    wait_until(lambda: system.incarnation("rcl") == 2, timeout=20, message="RCL restarted")
    assert system.pid("rcl", inc=2) != hung
    exits = wait_until(lambda: [e for e in system.sup_events("rcl") if e.event == "exit"],
                       timeout=10, message="sup exit of the RCL")
    assert "heartbeat" in exits[0].reason.lower() or "hung" in exits[0].reason
    after = wait_until(lambda: [s.state for inc, s in system.statuses(uuid) if inc == 2
                                and s.state == "cancelled"], timeout=10,
                       message="the abandoned patrol cancelled by incarnation 2")
    assert after == ["cancelled"]
    system.percept("patrol_goal(ugv2, g2, 2)")
    system.wait_state(system.request("patrol", "g2").uuid, "succeeded")
