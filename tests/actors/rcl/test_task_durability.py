"""Tasks addressed to a role across restarts and bad input, on an RCL core in-process
(real journal, real robot actors, simulated robots): a waiting task is journaled with
its action, so a restarted requester adopts it and a new run fails it explicitly; a
decommission outlives any restart; a cancelled waiting task, an award for a task
already done and a holder no longer configured lose no task and make no second
holder; a task decided at once is journaled held by its winner before the award goes
out; a journaled award waits for its robot's first link report after a restart,
and is bid for again when none comes."""

from __future__ import annotations

import sqlite3
from typing import Any

from mrss.actors.rcl.allocation.profile import RobotProfile
from mrss.actors.rcl.core import RclCore
from mrss.actors.rcl.journal import ActionJournal, Requester
from mrss.messages import (
    ActionControl,
    ActionInventory,
    ActionQuery,
    ActionRequest,
    ActionState,
    AllocationState,
    ControlCommand,
    ControlTarget,
    TaskAllocation,
)
from mrss.testing import wait_until
from tests.actors.rcl.rcl_sim import RclEnv, SimRobot

PROFILES = {r: RobotProfile(r, frozenset({"ugv"})) for r in ("ugv1", "ugv2")}
REASONER = Requester("reasoner", 1)


def _start(env: RclEnv, new_run: bool = False, robots: dict[str, SimRobot] | None = None,
           out: tuple[str, ...] = ("ugv1", "ugv2")) -> RclCore:
    """Start the core; the robots in `out` unavailable (a task for them waits)."""
    core = env.start(robots, new_run=new_run, profiles=PROFILES)
    for robot in out:
        core.availability.set_available(robot, False, "held by the test")
    return core


def _patrol(uuid: str, points: int = 1) -> ActionRequest:
    return ActionRequest(uuid=uuid, name="patrol", args=["any", f"g-{uuid}",
                                                         list(range(points))],
                         goal=f"g-{uuid}", role={"capabilities": ["ugv"]},
                         literal=f"patrol(any([ugv]), g_{uuid})")


def _allocations(env: RclEnv, uuid: str) -> list[TaskAllocation]:
    with env.statuses.lock:
        return [m for m in env.statuses.others if isinstance(m, TaskAllocation)
                and m.uuid == uuid]


def _awards(env: RclEnv, uuid: str) -> list[str]:
    return [a.robot for a in _allocations(env, uuid) if a.state is AllocationState.AWARDED]


def _waits(env: RclEnv, uuid: str) -> None:
    wait_until(lambda: any(a.state is AllocationState.WAITING for a in _allocations(env, uuid)),
               timeout=30, message=f"{uuid} waits")


def _tasks(env: RclEnv) -> dict[str, str]:
    with sqlite3.connect(str(env.journal_path)) as db:
        return dict(db.execute("SELECT uuid, robot FROM tasks").fetchall())


def _inventory(env: RclEnv) -> list[dict[str, Any]]:
    with env.statuses.lock:
        found = [m for m in env.statuses.others if isinstance(m, ActionInventory)]
    return found[-1].actions if found else []


def test_a_waiting_task_is_journaled_with_its_action_and_adopted_after_a_requester_restart(
        rcl_env: RclEnv) -> None:
    rcl_env.robots["ugv1"].auto = rcl_env.robots["ugv2"].auto = True
    core = _start(rcl_env)
    core.submit(_patrol("w1"), REASONER)
    _waits(rcl_env, "w1")
    entry = rcl_env.journal.get("w1") if rcl_env.journal else None
    assert entry is not None and (entry.action.state, entry.action.robot) == (
        ActionState.PENDING, "")
    assert entry.action.reason == "waiting for any robot with ugv"
    assert not rcl_env.statuses.of("w1")  # journaled, not published: no robot has it yet

    # the reasoner restarts: its inventory lists the waiting task, and it adopts it
    core.requesters.answer_query(ActionQuery(requester="reasoner", inc=2),
                                 Requester("reasoner", 2))
    assert [(i["uuid"], i["robot"], i["state"]) for i in _inventory(rcl_env)] == [
        ("w1", "", "pending")]
    core.submit(_patrol("w1"), Requester("reasoner", 2))
    core.availability.set_available("ugv2", True)
    wait_until(rcl_env.statuses.reached("w1", "succeeded"), timeout=30, message="w1 done")
    assert _awards(rcl_env, "w1") == ["ugv2"]
    done = rcl_env.journal.get("w1") if rcl_env.journal else None
    assert done is not None and done.requester == Requester("reasoner", 2)
    assert _tasks(rcl_env) == {}


def test_an_rcl_restart_keeps_a_waiting_task_and_awards_it_once(rcl_env: RclEnv) -> None:
    rcl_env.robots["ugv1"].auto = True
    core = _start(rcl_env)
    core.submit(_patrol("w2"), REASONER)
    _waits(rcl_env, "w2")
    rcl_env.stop()
    core = _start(rcl_env, out=("ugv2",))  # the same run: ugv1 is free now
    wait_until(rcl_env.statuses.reached("w2", "succeeded"), timeout=30, message="w2 done")
    assert _awards(rcl_env, "w2") == ["ugv1"]
    assert {s.robot for s in rcl_env.statuses.of("w2")} == {"ugv1"}


def test_a_new_run_fails_a_waiting_task_explicitly_instead_of_dropping_it(
        rcl_env: RclEnv) -> None:
    core = _start(rcl_env)
    core.submit(_patrol("w3"), REASONER)
    _waits(rcl_env, "w3")
    rcl_env.stop()
    _start(rcl_env, new_run=True, out=())
    last = rcl_env.statuses.last("w3")
    assert last is not None and last.state is ActionState.FAILED
    assert "left over from a previous run" in last.reason
    assert _tasks(rcl_env) == {} and _awards(rcl_env, "w3") == []


def test_a_waiting_task_cancelled_by_its_agent_is_never_awarded(rcl_env: RclEnv) -> None:
    rcl_env.robots["ugv1"].auto = True
    core = _start(rcl_env)
    core.submit(_patrol("w4"), REASONER)
    core.submit(_patrol("w5"), REASONER)
    _waits(rcl_env, "w4")
    _waits(rcl_env, "w5")
    assert core.control(ActionControl(command=ControlCommand.CANCEL, target="w4",
                                      target_kind=ControlTarget.ACTION),
                        src="reasoner") == ["w4"]
    last = rcl_env.statuses.last("w4")
    assert last is not None and last.state is ActionState.CANCELLED
    assert last.reason == "cancelled by the agent while it waited for a robot"
    core.availability.set_available("ugv1", True)  # w5 goes; w4 never does
    wait_until(rcl_env.statuses.reached("w5", "succeeded"), timeout=30, message="w5 done")
    assert _awards(rcl_env, "w4") == [] and rcl_env.statuses.states("w4") == ["cancelled"]
    assert _tasks(rcl_env) == {}


def test_an_award_for_a_task_already_done_is_dropped_and_counted(rcl_env: RclEnv) -> None:
    rcl_env.robots["ugv1"].auto = True
    core = _start(rcl_env, out=())
    core.submit(_patrol("w6"), REASONER)
    wait_until(rcl_env.statuses.reached("w6", "succeeded"), timeout=30, message="w6 done")
    before = len(rcl_env.statuses.of("w6"))
    core.award(_patrol("w6"), REASONER, "ugv2", {})  # a late award: the task is done
    assert len(rcl_env.statuses.of("w6")) == before  # nothing ran, nothing was said
    assert core.rejections.counts[("ugv2", "award for a task no longer open")] == 1


def test_decommission_outlives_rcl_restarts_and_new_runs(rcl_env: RclEnv) -> None:
    core = _start(rcl_env, out=())
    core.availability.decommission("ugv1", True)
    for new_run in (False, True):
        rcl_env.stop()
        core = _start(rcl_env, new_run=new_run, out=())
        refusal = core.availability.refusal("ugv1")
        assert refusal is not None and refusal[0] == "decommissioned by the operator"
        assert core.availability.refusal("ugv2") is None
    core.availability.decommission("ugv1", False)
    rcl_env.stop()
    assert _start(rcl_env, out=()).availability.refusal("ugv1") is None


def test_a_task_decided_at_once_is_journaled_held_by_its_winner_when_awarded(
        rcl_env: RclEnv) -> None:
    core = _start(rcl_env, out=("ugv2",))
    core.submit(_patrol("a1", points=3), REASONER)
    # decided on the submitting thread: awarded before submit returns, the task and its
    # award in the journal before the AWARDED went out (checked on every award published)
    assert _awards(rcl_env, "a1") == ["ugv1"]
    assert _tasks(rcl_env) == {"a1": "ugv1"}
    wait_until(rcl_env.statuses.reached("a1", "running"), timeout=30, message="a1 runs")
    rcl_env.stop()  # a restart: the task stays with ugv1, never decided again
    rcl_env.robots["ugv1"].auto = True
    _start(rcl_env, out=("ugv2",))
    wait_until(rcl_env.statuses.reached("a1", "succeeded"), timeout=30, message="a1 done")
    assert _awards(rcl_env, "a1") == ["ugv1"]
    assert {s.robot for s in rcl_env.statuses.of("a1")} == {"ugv1"}


def test_a_task_held_by_a_robot_no_longer_configured_goes_to_another(
        rcl_env: RclEnv) -> None:
    core = _start(rcl_env, out=("ugv2",))
    core.submit(_patrol("w7", points=3), REASONER)  # ugv1 takes it, and stops at point 0
    wait_until(rcl_env.statuses.reached("w7", "running"), timeout=30, message="w7 runs")
    assert _awards(rcl_env, "w7") == ["ugv1"]
    rcl_env.stop()
    rcl_env.robots["ugv2"].auto = True
    core = _start(rcl_env, robots={"ugv2": rcl_env.robots["ugv2"]}, out=())  # ugv1 removed
    wait_until(rcl_env.statuses.reached("w7", "succeeded"), timeout=30, message="w7 done")
    last = rcl_env.statuses.last("w7")
    assert last is not None and last.robot == "ugv2"
    assert last.cause == ""  # never failed on its way
    assert _awards(rcl_env, "w7") == ["ugv1", "ugv2"]


def _award_journaled_not_started(env: RclEnv, uuid: str) -> None:
    """A task waiting, then its award to ugv1 journaled and the RCL killed before the
    action started on it."""
    _start(env)
    assert env.core is not None
    env.core.submit(_patrol(uuid), REASONER)
    _waits(env, uuid)
    env.stop()
    journal = ActionJournal(env.journal_path)
    journal.hold_task(uuid, "ugv1")
    journal.close()


def test_a_journaled_award_waits_for_its_robots_first_report_after_a_restart(
        rcl_env: RclEnv) -> None:
    _award_journaled_not_started(rcl_env, "f1")
    rcl_env.robots["ugv1"].auto = True
    core = rcl_env.start(profiles=PROFILES, before_start=lambda c: c.availability
                         .await_first_reports({"ugv1": 60.0}, 0.0))
    assert core.availability.refusal("ugv1") is not None  # not heard yet: unavailable
    assert _tasks(rcl_env) == {"f1": "ugv1"} and not rcl_env.statuses.of("f1")
    core.availability.link_state("ugv1", True)  # its first report: the award is carried out
    wait_until(rcl_env.statuses.reached("f1", "succeeded"), timeout=30, message="f1 done")
    assert {s.robot for s in rcl_env.statuses.of("f1")} == {"ugv1"}
    assert _awards(rcl_env, "f1") == []  # carried out, never decided again
    core.availability.link_state("ugv1", True)  # a later report changes nothing
    assert [s.state for s in rcl_env.statuses.of("f1")].count(ActionState.SUCCEEDED) == 1


def test_a_journaled_award_is_bid_for_again_when_its_robot_never_reports(
        rcl_env: RclEnv) -> None:
    _award_journaled_not_started(rcl_env, "f2")
    rcl_env.robots["ugv2"].auto = True
    core = rcl_env.start(profiles=PROFILES, before_start=lambda c: c.availability
                         .await_first_reports({"ugv1": 3.0}, 0.0))
    core.availability.first_reports_due(1.0)  # within its link's timeout: still waits
    assert core.availability.awaiting("ugv1") and _tasks(rcl_env) == {"f2": "ugv1"}
    core.availability.first_reports_due(3.5)  # past it: ugv1 is lost, f2 goes to ugv2
    wait_until(rcl_env.statuses.reached("f2", "succeeded"), timeout=30, message="f2 done")
    assert _awards(rcl_env, "f2") == ["ugv2"]
    assert {s.robot for s in rcl_env.statuses.of("f2")} - {""} == {"ugv2"}
    refusal = core.availability.refusal("ugv1")
    assert refusal is not None and refusal[0] == ("link down: no first report within 3 s "
                                                  "of the RCL's start")
