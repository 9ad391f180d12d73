"""A control sent to a robot actor in the instant it crashes is applied by its successor."""

from __future__ import annotations

import sqlite3
import threading
from typing import Any

import pytest

from mrss.actors.rcl import controls
from mrss.actors.rcl import lifecycle as lc
from mrss.actors.rcl.core import RclCore
from mrss.actors.rcl.journal import ActionJournal
from mrss.errors import DecodeError
from mrss.messages import ActionControl, ActionState, FailureCause
from mrss.testing import wait_until
from tests.actors.rcl.rcl_sim import RclEnv, request_fields


class _StallThenFail(ActionJournal):
    """A journal whose armed progress write stalls until released, then fails: the robot
    actor is busy (its mailbox fills) and then crashes with what is in it."""

    def __init__(self, *args: Any, **kwargs: Any) -> None:
        super().__init__(*args, **kwargs)
        self.armed = False
        self.entered = threading.Event()
        self.release = threading.Event()

    def save_progress(self, uuid: str, progress: dict[str, Any]) -> None:
        if self.armed:
            self.armed = False
            self.entered.set()
            self.release.wait(30.0)
            raise sqlite3.OperationalError("disk I/O error")
        super().save_progress(uuid, progress)


def test_control_in_the_mailbox_of_a_crashing_robot_actor_is_applied_by_its_successor(
        rcl_env: RclEnv) -> None:
    journal = _StallThenFail(rcl_env.journal_path)
    ugv = rcl_env.robots["ugv1"]
    core = RclCore(rcl_env.layer, journal, rcl_env.statuses, {"ugv1": ugv})
    core.start()
    try:
        core.submit_fields(request_fields("a1", "patrol", "ugv1", "g1", ["p1", "p2", "p3"]))
        wait_until(lambda: ugv.is_moving_to("p1"))
        journal.armed = True
        ugv.arrive()  # reaching p1 records progress: the robot actor stalls in the write
        wait_until(journal.entered.is_set, message="robot actor busy")
        assert core.control(ActionControl("cancel", "a1")) == ["a1"]  # into its mailbox
        assert [u for _, u, _ in journal.pending_controls("ugv1")] == ["a1"]
        journal.release.set()  # the write fails: the actor dies with the cancel unread
        wait_until(rcl_env.statuses.reached("a1", "cancelled"), message="cancel applied")
        last = rcl_env.statuses.last("a1")
        assert last is not None and last.cause == FailureCause.CANCELLED
        assert any(getattr(m, "event", "") == "restart" for m in rcl_env.statuses.others)
        assert journal.pending_controls("ugv1") == []
        assert ugv.halts >= 1  # the successor restarted the patrol, the cancel stopped it
        assert rcl_env.statuses.states("a1").count("cancelled") == 1
    finally:
        journal.release.set()
        ugv.halt()
        core.stop()
        journal.close()


def test_control_applied_by_the_live_actor_is_no_longer_pending(rcl_env: RclEnv) -> None:
    core = rcl_env.start()
    rcl_env.robots["ugv1"].auto = False
    core.submit_fields(request_fields("a1", "patrol", "ugv1", "g1", ["p1"]))
    wait_until(lambda: rcl_env.robots["ugv1"].is_moving_to("p1"))
    core.control(ActionControl("suspend", "a1"))
    wait_until(rcl_env.statuses.reached("a1", "suspended"))
    assert rcl_env.journal is not None
    wait_until(lambda: rcl_env.journal is not None
               and rcl_env.journal.pending_controls("ugv1") == [], message="claimed")
    rcl_env.robots["ugv1"].halt()


@pytest.mark.parametrize("event", [
    lc.Suspend(lc.SuspendCause.OPERATOR, "by hand"),
    lc.Resume(lc.SuspendCause.PREEMPTED, teleop=True),
    lc.End(ActionState.CANCELLED, lc.EndCause.ORPHANED, "orphaned: gone"),
    lc.End(ActionState.FAILED, lc.EndCause.LINK_LOST, "unreachable", FailureCause.LINK_DOWN),
])
def test_a_journaled_control_reads_back_as_the_same_event(event: controls.ControlEvent) -> None:
    assert controls.decode(controls.encode(event)) == event


def test_a_corrupt_journaled_control_is_a_clear_error() -> None:
    with pytest.raises(DecodeError, match="journaled control.*'wobble'"):
        controls.decode('{"kind": "suspend", "by": "wobble"}')
    with pytest.raises(DecodeError, match="expected a suspend, resume or end"):
        controls.decode('{"kind": "stopped", "by": "agent"}')
