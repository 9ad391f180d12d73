"""A robot whose battery falls below its `battery_critical` is lost for the tasks addressed
to a role it holds, on an RCL core in-process (real journal, real robot actors,
simulated robots whose link says its battery): the task goes to another robot from its
progress, the agent's action does not fail and it hears `reassigned`; an action
addressed to that robot by name runs on."""

from __future__ import annotations

from mrss.actors.rcl.allocation.profile import RobotProfile
from mrss.actors.rcl.journal import Requester
from mrss.messages import ActionRequest, ActionState, AllocationState, Percept, TaskAllocation
from mrss.testing import wait_until
from tests.actors.rcl.rcl_sim import RclEnv

PROFILES = {r: RobotProfile(r, frozenset({"ugv"}), battery_critical=15.0)
            for r in ("ugv1", "ugv2")}
REASONER = Requester("reasoner", 1)


def _patrol(uuid: str, robot: str = "") -> ActionRequest:
    role = {} if robot else {"capabilities": ["ugv"]}
    return ActionRequest(uuid=uuid, name="patrol",
                         args=[robot or "any", f"g-{uuid}", [1, 2, 3, 4]], robot=robot,
                         goal=f"g-{uuid}", role=role,
                         literal=f"patrol({robot or 'any([ugv])'}, g_{uuid})")


def _awards(env: RclEnv, uuid: str) -> list[TaskAllocation]:
    with env.statuses.lock:
        return [m for m in env.statuses.others if isinstance(m, TaskAllocation)
                and m.uuid == uuid and m.state is AllocationState.AWARDED]


def _progress(env: RclEnv, uuid: str) -> object:
    entry = env.journal.get(uuid) if env.journal is not None else None
    return entry.action.progress.get("waypoint") if entry is not None else None


def _percepts(env: RclEnv) -> list[str]:
    with env.statuses.lock:
        return [m.literal for m in env.statuses.others if isinstance(m, Percept)]


def test_a_critical_battery_hands_a_role_task_on_from_its_progress(rcl_env: RclEnv) -> None:
    ugv1, ugv2 = rcl_env.robots["ugv1"], rcl_env.robots["ugv2"]
    ugv1.battery = ugv2.battery = 80.0  # type: ignore[attr-defined]
    core = rcl_env.start(profiles=PROFILES)
    core.availability.set_available("ugv2", False, "held by the test")
    core.submit(_patrol("b1"), REASONER)
    wait_until(lambda: bool(_awards(rcl_env, "b1")), timeout=30, message="b1 awarded")
    assert _awards(rcl_env, "b1")[0].robot == "ugv1"
    ugv1.arrive(2)
    wait_until(lambda: _progress(rcl_env, "b1") == 2, timeout=30,
               message="ugv1 at its second waypoint")
    core.check_batteries()  # 80 %: nothing happens
    assert [a.robot for a in _awards(rcl_env, "b1")] == ["ugv1"]

    core.availability.set_available("ugv2", True)
    ugv1.battery = 12.0  # type: ignore[attr-defined]
    core.check_batteries()
    core.check_batteries()  # a second tick changes nothing: handed back once
    wait_until(lambda: len(_awards(rcl_env, "b1")) == 2, timeout=30, message="b1 re-awarded")
    again = _awards(rcl_env, "b1")[1]
    assert again.robot == "ugv2" and again.why.startswith("reassigned from ugv1 (lost)")
    ugv2.arrive(2)
    wait_until(rcl_env.statuses.reached("b1", "succeeded"), timeout=30, message="b1 done")
    assert ugv2.visited == [3, 4]  # from where ugv1 stopped
    released = next(s for s in rcl_env.statuses.of("b1")
                    if s.state is ActionState.PENDING and not s.robot and s.progress)
    assert released.reason == ("reassigning: robot ugv1's battery is at 12 %, below its "
                               "critical 15 %")
    assert ActionState.FAILED not in rcl_env.statuses.states("b1")  # the agent never saw it
    wait_until(lambda: "reassigned(patrol(any([ugv]), g_b1), ugv1, ugv2)" in _percepts(rcl_env),
               timeout=30, message="the reassigned percept")
    assert [a.robot for a in _awards(rcl_env, "b1")] == ["ugv1", "ugv2"]


def test_a_named_action_runs_on_when_its_robots_battery_is_critical(rcl_env: RclEnv) -> None:
    ugv1 = rcl_env.robots["ugv1"]
    ugv1.battery = 5.0  # type: ignore[attr-defined]
    core = rcl_env.start(profiles=PROFILES)
    core.submit(_patrol("n1", robot="ugv1"), REASONER)
    wait_until(rcl_env.statuses.reached("n1", "running"), timeout=30, message="n1 runs")
    core.check_batteries()
    ugv1.arrive(4)
    wait_until(rcl_env.statuses.reached("n1", "succeeded"), timeout=30, message="n1 done")
    assert ActionState.FAILED not in rcl_env.statuses.states("n1")
