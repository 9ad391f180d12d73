"""Requester incarnations: a new reasoner adopts what its predecessor left or, after a
grace, the RCL cancels those orphans; reconciliation answers from the journal."""

from __future__ import annotations

from mrss.actors.rcl.journal import Requester
from mrss.api import Action, CommandRejected, CommandTimeout, LinkDown, Skill, TransientError
from mrss.messages import (
    ActionInventory,
    ActionQuery,
    ActionRequest,
    FailureCause,
    across_runs,
)
from mrss.testing import wait_until
from tests.actors.rcl.rcl_sim import RclEnv


def _req(uuid: str, robot: str, goal: str = "g") -> ActionRequest:
    return ActionRequest(uuid=uuid, name="patrol", args=[robot, goal, ["p1"]],
                         literal=f"patrol({robot},{goal},[p1])")


def test_orphans_of_a_dead_incarnation_are_cancelled_once_the_grace_is_over(
    rcl_env: RclEnv,
) -> None:
    core = rcl_env.start()
    core.submit(_req("old1", "ugv1"), Requester("reasoner", 1))
    core.submit(_req("other", "ugv2"), Requester("operator", 1))
    wait_until(rcl_env.statuses.reached("old1", "running"))
    wait_until(rcl_env.statuses.reached("other", "running"))

    assert core.requesters.saw_incarnation("reasoner", 2) == ["old1"]
    assert core.requesters.cancel_orphans() == []  # within the grace: it keeps running
    assert "old1" in core.observers.active()
    rcl_env.now += core.requesters.orphans.grace + 0.1
    assert core.requesters.cancel_orphans() == ["old1"]
    wait_until(rcl_env.statuses.reached("old1", "cancelled"))
    last = rcl_env.statuses.last("old1")
    assert last is not None and "orphaned: reasoner incarnation 1 is gone" in last.reason
    assert last.cause == FailureCause.ORPHANED
    assert core.requesters.saw_incarnation("reasoner", 2) == []  # once per incarnation
    assert list(core.observers.active()) == ["other"]
    # (late requests of incarnation 1 never reach the core: the bus drops them, see
    # tests/bus/test_bus_incarnations.py and tests/actors/rcl/test_rcl_bus.py)


def test_a_new_incarnation_adopts_an_orphan_by_asking_for_its_uuid(rcl_env: RclEnv) -> None:
    core = rcl_env.start()
    core.submit(_req("old1", "ugv1", "a1"), Requester("reasoner", 1))
    wait_until(rcl_env.statuses.reached("old1", "running"))
    core.requesters.saw_incarnation("reasoner", 2)

    core.requesters.answer_query(ActionQuery(requester="reasoner", inc=2), Requester("reasoner", 2))
    inventories = [m for m in rcl_env.statuses.others if isinstance(m, ActionInventory)]
    assert len(inventories) == 1 and inventories[0].inc == 2
    [item] = inventories[0].actions
    assert item["uuid"] == "old1" and item["literal"] == "patrol(ugv1,a1,[p1])"
    assert item["state"] == "running"

    before = len(rcl_env.statuses.of("old1"))
    core.submit(_req("old1", "ugv1", "a1"), Requester("reasoner", 2))  # the adoption
    assert len(rcl_env.statuses.of("old1")) == before + 1  # its status again, for the new one
    assert rcl_env.journal is not None
    entry = rcl_env.journal.get("old1")
    assert entry is not None and entry.requester == Requester("reasoner", 2)
    rcl_env.now += core.requesters.orphans.grace_suspended + 1
    assert core.requesters.cancel_orphans() == []  # adopted: no orphan any more
    assert "old1" in core.observers.active()
    states = [state.value for state, _ in rcl_env.journal.transitions("old1")]
    assert states == ["pending", "running"]  # never cancelled and started again


def test_a_reasoner_on_another_node_adopts_across_its_nodes_root_restart(
        rcl_env: RclEnv) -> None:
    """The reasoner runs on another node: the RCL knows it by the numbers the border
    gives (mrss/bus/border.py), while the reasoner asks in its own (1 again after its
    node's root restarted). Its new run's inventory holds what the last run left, and
    answers in the asker's words."""
    core = rcl_env.start()
    last_run, new_run = across_runs(1_700_000_000_000, 3), across_runs(1_700_000_100_000, 1)
    core.submit(_req("old1", "ugv1", "a1"), Requester("reasoner", last_run))
    wait_until(rcl_env.statuses.reached("old1", "running"))

    core.requesters.answer_query(ActionQuery(requester="reasoner", inc=1),
                                 Requester("reasoner", new_run))
    inventories = [m for m in rcl_env.statuses.others if isinstance(m, ActionInventory)]
    assert len(inventories) == 1 and inventories[0].inc == 1  # as the reasoner asked
    assert [item["uuid"] for item in inventories[0].actions] == ["old1"]
    core.submit(_req("old1", "ugv1", "a1"), Requester("reasoner", new_run))  # adopted
    rcl_env.now += core.requesters.orphans.grace_suspended + 1
    assert core.requesters.cancel_orphans() == []
    assert "old1" in core.observers.active()


def test_reconciliation_answers_each_known_uuid_from_the_journal(rcl_env: RclEnv) -> None:
    core = rcl_env.start()
    core.submit(_req("a", "ugv1"), Requester("reasoner", 1))
    wait_until(rcl_env.statuses.reached("a", "running"))
    before = len(rcl_env.statuses.of("a"))
    assert core.requesters.answer_query(ActionQuery(uuids=["a", "never-seen"])) == 1
    assert len(rcl_env.statuses.of("a")) == before + 1
    assert rcl_env.statuses.last("a") is not None
    assert rcl_env.statuses.of("never-seen") == []


def test_first_request_of_a_new_incarnation_marks_orphans_even_after_restart(
    rcl_env: RclEnv,
) -> None:
    core = rcl_env.start()
    core.submit(_req("old1", "ugv1"), Requester("reasoner", 4))
    wait_until(rcl_env.statuses.reached("old1", "running"))
    rcl_env.stop()
    core = rcl_env.start()
    wait_until(lambda: any("RCL restart" in s.reason for s in rcl_env.statuses.of("old1")))
    core.submit(_req("new1", "ugv2"), Requester("reasoner", 5))
    rcl_env.now += core.requesters.orphans.grace + 0.1
    assert core.requesters.cancel_orphans() == ["old1"]
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


class _Away(Skill):
    """A skill whose dependency is away: it raises a TransientError."""

    max_restarts = 0

    def run(self) -> bool:
        raise TransientError("world model restarting")


def test_a_transient_failure_reaches_the_status_as_its_cause(rcl_env: RclEnv) -> None:
    def refine_away(action: Action) -> list[Skill]:
        raise TransientError("data layer: no reply within 2s")

    rcl_env.layer.recipes["away"] = lambda a: [_Away()]
    rcl_env.layer.recipes["ungrounded"] = refine_away
    core = rcl_env.start()
    core.submit(ActionRequest(uuid="s1", name="away", args=["ugv1", "g1"]))
    core.submit(ActionRequest(uuid="r1", name="ungrounded", args=["ugv2", "g2"]))
    for uuid in ("s1", "r1"):
        wait_until(rcl_env.statuses.reached(uuid, "failed"))
        last = rcl_env.statuses.last(uuid)
        assert last is not None and last.cause == FailureCause.TRANSIENT, last
    assert rcl_env.journal is not None
    entry = rcl_env.journal.get("s1")
    assert entry is not None and entry.action.cause == FailureCause.TRANSIENT  # journaled


class _Raises(Skill):
    """A skill that fails the way a robot link makes it fail: it raises `error`."""

    max_restarts = 0

    def __init__(self, error: Exception) -> None:
        self.error = error

    def run(self) -> bool:
        raise self.error


def test_a_skill_that_loses_its_robot_fails_with_a_cause_worth_a_retry(
        rcl_env: RclEnv) -> None:
    """A link that finds the robot gone (LinkDown) before the RCL hears of it, or a robot
    that answers no command (CommandTimeout: out of range, restarting), fails the action
    with a cause a plan retries (chaos seeds 7 and 8: `action_failed` ended the goal for
    good after a 2 s radio loss); a refusal stays `action_failed`."""
    errors = {"down": LinkDown("ugv1", "last will: offline (while waiting: teleop)"),
              "silent": CommandTimeout("ugv2", "goto", 1.0, 3),
              "refused": CommandRejected("ugv1", "arm", "denied")}
    for name, error in errors.items():
        rcl_env.layer.recipes[name] = lambda a, e=error: [_Raises(e)]
    core = rcl_env.start()
    core.submit(ActionRequest(uuid="d1", name="down", args=["ugv1", "g1"]))
    core.submit(ActionRequest(uuid="t1", name="silent", args=["ugv2", "g2"]))
    expected = {"d1": FailureCause.LINK_DOWN, "t1": FailureCause.TRANSIENT, "x1": ""}
    for uuid in ("d1", "t1"):
        wait_until(rcl_env.statuses.reached(uuid, "failed"))
    core.submit(ActionRequest(uuid="x1", name="refused", args=["ugv1", "g3"]))
    wait_until(rcl_env.statuses.reached("x1", "failed"))
    for uuid, cause in expected.items():
        last = rcl_env.statuses.last(uuid)
        assert last is not None and last.cause == cause, last


def test_a_request_for_an_unavailable_robot_is_refused_with_the_cause_of_it(
        rcl_env: RclEnv) -> None:
    core = rcl_env.start()
    core.availability.link_state("ugv1", False, "no heartbeat for 3.0 s")
    core.submit(ActionRequest(uuid="r1", name="patrol", args=["ugv1", "g1", ["p1"]]))
    wait_until(rcl_env.statuses.reached("r1", "failed"))
    last = rcl_env.statuses.last("r1")
    assert last is not None and last.cause == FailureCause.LINK_DOWN  # worth a retry later
    assert "unavailable" in last.reason
    core.availability.link_state("ugv1", True)
    core.submit(ActionRequest(uuid="r2", name="patrol", args=["ugv1", "g1", ["p1"]]))
    wait_until(rcl_env.statuses.reached("r2", "running"))
    core.submit(ActionRequest(uuid="r3", name="patrol", args=[]))  # malformed: rejected
    wait_until(rcl_env.statuses.reached("r3", "failed"))
    last = rcl_env.statuses.last("r3")
    assert last is not None and last.cause == FailureCause.REJECTED
