"""Requester incarnations: a new reasoner cancels its predecessor's orphans; late requests
from a dead incarnation are refused, also across an RCL restart."""

from __future__ import annotations

from mrss.actors.journal import Requester
from mrss.messages import ActionRequest
from mrss.testing import wait_until
from tests.actors.rcl_sim import RclEnv


def _req(uuid: str, robot: str) -> ActionRequest:
    return ActionRequest(uuid=uuid, name="patrol", args=[robot, "g", ["p1"]])


def test_new_incarnation_cancels_the_old_ones_actions(rcl_env: RclEnv) -> None:
    core = rcl_env.start()
    core.submit(_req("old1", "ugv1"), Requester("reasoner", 1))
    core.submit(_req("other", "ugv2"), Requester("operator", 1))
    wait_until(rcl_env.statuses.reached("old1", "running"))
    wait_until(rcl_env.statuses.reached("other", "running"))

    assert core.saw_incarnation("reasoner", 2) == ["old1"]
    wait_until(rcl_env.statuses.reached("old1", "cancelled"))
    last = rcl_env.statuses.last("old1")
    assert last is not None and "orphaned: reasoner incarnation 1 is gone" in last.reason
    assert core.saw_incarnation("reasoner", 2) == []  # once per incarnation
    assert list(core.active()) == ["other"]

    core.submit(_req("late", "uav1"), Requester("reasoner", 1))
    wait_until(rcl_env.statuses.reached("late", "failed"))
    last = rcl_env.statuses.last("late")
    assert last is not None and "incarnation 1, which is gone" in last.reason


def test_first_request_of_a_new_incarnation_cancels_orphans_even_after_restart(
    rcl_env: RclEnv,
) -> None:
    core = rcl_env.start()
    core.submit(_req("old1", "ugv1"), Requester("reasoner", 4))
    wait_until(rcl_env.statuses.reached("old1", "running"))
    rcl_env.stop()
    core = rcl_env.start()
    wait_until(lambda: any("RCL restart" in s.reason for s in rcl_env.statuses.of("old1")))
    core.submit(_req("late", "uav1"), Requester("reasoner", 3))  # older than the journal's
    wait_until(rcl_env.statuses.reached("late", "failed"))
    core.submit(_req("new1", "ugv2"), Requester("reasoner", 5))
    wait_until(rcl_env.statuses.reached("old1", "cancelled"))
    wait_until(rcl_env.statuses.reached("new1", "running"))
    assert rcl_env.journal is not None
    entry = rcl_env.journal.get("new1")
    assert entry is not None and entry.requester == Requester("reasoner", 5)



def test_a_new_run_fails_what_a_previous_run_left_open(rcl_env: RclEnv) -> None:
    core = rcl_env.start()
    core.submit(_req("old1", "ugv1"), Requester("reasoner", 7))
    wait_until(rcl_env.statuses.reached("old1", "running"))
    rcl_env.stop()
    core = rcl_env.start(new_run=True)
    wait_until(rcl_env.statuses.reached("old1", "failed"))
    last = rcl_env.statuses.last("old1")
    assert last is not None and "previous run" in last.reason
    core.submit(_req("new1", "ugv1"), Requester("reasoner", 1))  # numbering starts over
    wait_until(rcl_env.statuses.reached("new1", "running"))
