"""Resources across actions: pre-emption by priority, resumption, waiting for equals."""

from __future__ import annotations

import time

from mrss.actors.rcl.core import RclCore
from mrss.messages import ActionControl, FailureCause
from mrss.testing import wait_until
from tests.actors.rcl.rcl_sim import RclEnv, request_fields


def _hold(core: RclCore, uuid: str, robot: str, waypoint: str, priority: int) -> None:
    core.submit_fields(request_fields(uuid, "hold", robot, "g-" + uuid, "airspace", waypoint,
                                      priority=priority))


def test_higher_priority_preempts_and_the_lower_resumes_when_free(rcl_env: RclEnv) -> None:
    core = rcl_env.start()
    ugv, uav = rcl_env.robots["ugv1"], rcl_env.robots["uav1"]
    _hold(core, "low", "ugv1", "x", priority=1)
    wait_until(lambda: ugv.is_moving_to("x"))
    assert core.broker.holders("airspace") == {"low"}

    _hold(core, "high", "uav1", "y", priority=5)
    wait_until(rcl_env.statuses.reached("low", "suspended"))
    suspended = rcl_env.statuses.last("low")
    assert suspended is not None and "pre-empted: airspace" in suspended.reason
    assert ugv.halts == 1
    wait_until(lambda: uav.is_moving_to("y"))
    assert core.broker.holders("airspace") == {"high"}

    uav.arrive()
    wait_until(rcl_env.statuses.reached("high", "succeeded"))
    wait_until(lambda: ugv.is_moving_to("x"), message="low resumed once airspace was free")
    # the robot may move before the RUNNING of the resumption is published: wait for it
    wait_until(lambda: rcl_env.statuses.states("low") == ["pending", "running", "suspended",
                                                          "running"],
               message="low: pending, running, suspended, running")
    ugv.arrive()
    wait_until(rcl_env.statuses.reached("low", "succeeded"))
    assert core.broker.holders("airspace") == set()


def test_equal_priority_waits_without_preempting(rcl_env: RclEnv) -> None:
    core = rcl_env.start()
    ugv, uav = rcl_env.robots["ugv1"], rcl_env.robots["uav1"]
    _hold(core, "first", "ugv1", "x", priority=3)
    wait_until(lambda: ugv.is_moving_to("x"))
    _hold(core, "second", "uav1", "y", priority=3)
    wait_until(lambda: core.broker.waiting("airspace") == ["second"])
    assert not uav.is_moving_to("y") and core.broker.holders("airspace") == {"first"}
    ugv.arrive()
    wait_until(rcl_env.statuses.reached("first", "succeeded"))
    wait_until(lambda: uav.is_moving_to("y"))
    uav.arrive()
    wait_until(rcl_env.statuses.reached("second", "succeeded"))
    assert "suspended" not in rcl_env.statuses.states("first")
    assert ugv.halts == 0


def test_lower_priority_waits_and_waiters_are_served_by_priority(rcl_env: RclEnv) -> None:
    core = rcl_env.start()
    ugv, uav, ugv2 = rcl_env.robots["ugv1"], rcl_env.robots["uav1"], rcl_env.robots["ugv2"]
    _hold(core, "owner", "ugv1", "x", priority=5)
    wait_until(lambda: ugv.is_moving_to("x"))
    _hold(core, "low", "uav1", "y", priority=1)
    wait_until(lambda: core.broker.waiting("airspace") == ["low"])
    _hold(core, "mid", "ugv2", "z", priority=3)
    wait_until(lambda: core.broker.waiting("airspace") == ["mid", "low"])
    ugv.arrive()
    wait_until(lambda: ugv2.is_moving_to("z"), message="mid served before low")
    assert core.broker.waiting("airspace") == ["low"]
    ugv2.arrive()
    wait_until(lambda: uav.is_moving_to("y"))
    uav.arrive()
    wait_until(rcl_env.statuses.reached("low", "succeeded"))


def test_cancelled_preemptor_lets_the_preempted_action_resume(rcl_env: RclEnv) -> None:
    core = rcl_env.start()
    ugv = rcl_env.robots["ugv1"]
    _hold(core, "low", "ugv1", "x", priority=1)
    wait_until(lambda: ugv.is_moving_to("x"))
    _hold(core, "high", "uav1", "y", priority=5)
    wait_until(rcl_env.statuses.reached("low", "suspended"))
    core.control(ActionControl("cancel", "high"))
    wait_until(rcl_env.statuses.reached("high", "cancelled"))
    wait_until(lambda: ugv.is_moving_to("x"))
    wait_until(rcl_env.statuses.reached("low", "running"))


def test_preempted_action_suspended_by_control_stays_suspended(rcl_env: RclEnv) -> None:
    core = rcl_env.start()
    ugv, uav = rcl_env.robots["ugv1"], rcl_env.robots["uav1"]
    _hold(core, "low", "ugv1", "x", priority=1)
    wait_until(lambda: ugv.is_moving_to("x"))
    _hold(core, "high", "uav1", "y", priority=5)
    wait_until(rcl_env.statuses.reached("low", "suspended"))
    core.control(ActionControl("suspend", "low"))  # the reasoner takes ownership
    uav.arrive()
    wait_until(rcl_env.statuses.reached("high", "succeeded"))
    core.submit_fields(request_fields("flush", "noop", "ugv1", "g"))
    wait_until(rcl_env.statuses.reached("flush", "succeeded"))
    assert core.observers.active()["low"].value == "suspended"
    core.control(ActionControl("resume", "low"))
    wait_until(lambda: ugv.is_moving_to("x"))


def test_with_preempted_timeout_an_action_preempted_too_long_fails_as_preempted(
        rcl_env: RclEnv) -> None:
    core = rcl_env.start(preempted_timeout=0.2)
    ugv, uav = rcl_env.robots["ugv1"], rcl_env.robots["uav1"]
    _hold(core, "low", "ugv1", "x", priority=1)
    wait_until(lambda: ugv.is_moving_to("x"))
    _hold(core, "high", "uav1", "y", priority=5)
    wait_until(rcl_env.statuses.reached("low", "failed"), message="low failed after 0.2 s")
    failed = rcl_env.statuses.last("low")
    assert failed is not None and failed.cause == FailureCause.PREEMPTED
    assert failed.reason == "pre-empted for more than 0.2s (preempted_timeout)"
    assert rcl_env.statuses.states("low") == ["pending", "running", "suspended", "failed"]
    assert core.broker.waiting("airspace") == [] and uav.is_moving_to("y")
    uav.arrive()
    wait_until(rcl_env.statuses.reached("high", "succeeded"))
    assert not ugv.is_moving_to("x")  # nothing left to resume


def test_a_preempted_action_resumed_in_time_is_not_failed_by_the_timeout(
        rcl_env: RclEnv) -> None:
    # Each episode below usually ends well within the timeout; the test measures how long
    # each took from its own side (a bound on the RCL's suspension) and asserts the
    # outcome only where that bound decides it, so a slow machine can't fail it.
    timeout = 3.0
    core = rcl_env.start(preempted_timeout=timeout)
    ugv, uav = rcl_env.robots["ugv1"], rcl_env.robots["uav1"]

    def low_failed() -> bool:
        last = rcl_env.statuses.last("low")
        return last is not None and last.state == "failed"

    _hold(core, "low", "ugv1", "x", priority=1)
    wait_until(lambda: ugv.is_moving_to("x"), message="low running")
    first, longest = time.monotonic(), 0.0
    for n in range(2):  # pre-empted twice, resumed each time: each episode has its own timer
        began = time.monotonic()
        _hold(core, f"high{n}", "uav1", "y", priority=5)
        wait_until(lambda: uav.is_moving_to("y"))
        uav.arrive()
        wait_until(rcl_env.statuses.reached(f"high{n}", "succeeded"))
        wait_until(lambda: ugv.is_moving_to("x") or low_failed(), message="low resumed")
        longest = max(longest, time.monotonic() - began)
    # Not a synchronisation: a timer left running from either episode fires by then.
    time.sleep(max(0.0, first + timeout + 0.5 - time.monotonic()))
    if longest >= timeout:  # this machine was too slow for an episode to tell
        last = rcl_env.statuses.last("low")
        assert last is not None
        assert last.state == "running" or (
            last.state == "failed" and "preempted_timeout" in last.reason), last
        return
    assert not low_failed(), rcl_env.statuses.last("low")
    ugv.arrive()
    wait_until(rcl_env.statuses.reached("low", "succeeded"))
    assert rcl_env.statuses.states("low") == [
        "pending", "running", "suspended", "running", "suspended", "running", "succeeded"]
