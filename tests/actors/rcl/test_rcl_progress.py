"""The RCL's progress feed and snapshot: repeat statuses observers see, never transitions."""

from __future__ import annotations

from mrss.actors.rcl.skill import progress_bound_of
from mrss.messages import ActionStatus, RobotState
from mrss.testing import wait_until
from tests.actors.rcl.rcl_sim import Patrol, RclEnv, request_fields


def _progress(env: RclEnv, uuid: str) -> list[object]:
    return [s.progress.get("waypoint") for s in env.statuses.of(uuid) if s.repeat]


def test_recorded_progress_goes_out_throttled_as_repeat_statuses_and_never_after_the_end(
        rcl_env: RclEnv) -> None:
    core = rcl_env.start(progress_every=1.0)
    robot = rcl_env.robots["ugv1"]
    core.submit_fields(request_fields("a1", "patrol", "ugv1", "g1", ["p1", "p2", "p3", "p4"]))
    wait_until(rcl_env.statuses.reached("a1", "running"), message="a1 running")
    robot.arrive(1)  # the first progress after a quiet time goes out at once
    wait_until(lambda: _progress(rcl_env, "a1") == [1], message="first progress status")
    first = [s for s in rcl_env.statuses.of("a1") if s.repeat][0]
    assert (first.state, first.robot, first.name, first.goal) == ("running", "ugv1",
                                                                   "patrol", "g1")
    robot.arrive(1)  # within the second: it waits
    journal = rcl_env.journal
    assert journal is not None

    def journaled() -> object:
        entry = journal.get("a1")
        return entry.action.progress.get("waypoint") if entry is not None else None

    wait_until(lambda: journaled() == 2, message="second progress journaled")
    assert core.observers.publish_progress() == 0 and _progress(rcl_env, "a1") == [1]
    rcl_env.now += 1.0  # a second later the newest value goes out (the heartbeat's call)
    assert core.observers.publish_progress() == 1 and _progress(rcl_env, "a1") == [1, 2]
    robot.arrive(2)
    wait_until(rcl_env.statuses.reached("a1", "succeeded"), message="a1 succeeded")
    rcl_env.now += 5.0
    assert core.observers.publish_progress() == 0  # ended: nothing more of it
    statuses = rcl_env.statuses.of("a1")
    assert statuses[-1].state == "succeeded" and not statuses[-1].repeat
    assert [s.state for s in statuses if not s.repeat] == ["pending", "running", "succeeded"]
    assert all(s.state == "running" for s in statuses if s.repeat)


def test_progress_feed_is_off_by_default_in_the_core(rcl_env: RclEnv) -> None:
    rcl_env.robots["ugv1"].auto = True
    core = rcl_env.start()
    core.submit_fields(request_fields("a1", "patrol", "ugv1", "g1", ["p1", "p2"]))
    wait_until(rcl_env.statuses.reached("a1", "succeeded"), message="a1 succeeded")
    assert not any(s.repeat for s in rcl_env.statuses.of("a1"))


def test_snapshot_sends_every_robot_state_and_every_open_action_as_repeats(
        rcl_env: RclEnv) -> None:
    core = rcl_env.start()
    core.submit_fields(request_fields("a1", "patrol", "ugv1", "g1", ["p1"]))
    core.submit_fields(request_fields("a2", "patrol", "ugv2", "g2", ["p9"]))
    rcl_env.robots["ugv2"].arrive(1)
    wait_until(rcl_env.statuses.reached("a1", "running"), message="a1 running")
    wait_until(rcl_env.statuses.reached("a2", "succeeded"), message="a2 done")
    core.availability.set_teleop("uav1", True)
    before = len(rcl_env.statuses.others)
    assert core.observers.snapshot() == 1  # a1 only: a2 has ended
    repeat = rcl_env.statuses.last("a1")
    assert repeat == ActionStatus(uuid="a1", state="running", robot="ugv1", repeat=True,
                                  name="patrol", goal="g1")
    states = {m.robot: m for m in rcl_env.statuses.others[before:]
              if isinstance(m, RobotState)}
    assert sorted(states) == ["uav1", "ugv1", "ugv2"]
    assert states["uav1"].attributes == {"teleop": True}
    assert states["ugv1"].available and states["ugv1"].link == "up"


class _BoundedPatrol(Patrol):
    progress_bound = 45.0


def test_the_running_status_carries_the_progress_bound_of_the_actions_skills(
        rcl_env: RclEnv) -> None:
    rcl_env.layer.recipes["bounded"] = lambda a: [_BoundedPatrol(list(a.args[2]))]  # type: ignore[arg-type]
    rcl_env.layer.recipes["mixed"] = lambda a: [_BoundedPatrol(list(a.args[2])),  # type: ignore[arg-type]
                                                Patrol(["q"])]
    core = rcl_env.start()
    core.submit_fields(request_fields("a1", "bounded", "ugv1", "g1", ["p1"]))
    core.submit_fields(request_fields("a2", "mixed", "ugv2", "g2", ["p2"]))
    core.submit_fields(request_fields("a3", "patrol", "uav1", "g3", ["p3"]))
    for uuid in ("a1", "a2", "a3"):
        wait_until(rcl_env.statuses.reached(uuid, "running"), message=f"{uuid} running")
    running = {u: next(s for s in rcl_env.statuses.of(u) if s.state == "running")
               for u in ("a1", "a2", "a3")}
    assert running["a1"].progress_bound == 45.0
    assert running["a2"].progress_bound == 0.0  # a skill without a bound: no promise
    assert running["a3"].progress_bound == 0.0
    assert all(s.progress_bound == 0.0 for s in rcl_env.statuses.of("a1")
               if s.state == "pending")


def test_progress_bound_of_skills_is_the_loosest_when_all_declare_one() -> None:
    class Fast(Patrol):
        progress_bound = 5.0

    assert progress_bound_of([Fast([]), _BoundedPatrol([])]) == 45.0
    assert progress_bound_of([Fast([]), Patrol([])]) == 0.0
    assert progress_bound_of([]) == 0.0
