"""Fault injection into nested actor supervisors (robot -> skill actors)."""

from __future__ import annotations

from collections.abc import Iterator
from typing import Any

import pykka
import pytest

from mrss.supervision.actors import ActorSupervisor, CrashNow, actor_child
from mrss.supervision.events import EventLog
from mrss.supervision.spec import Backoff, ChildKind, OnExceeded, SupervisorSpec
from mrss.testing import wait_until
from tests.projects.actorkit import Store, counter, nested, stop_every_actor

FAST = Backoff(initial=0.0)


@pytest.fixture(autouse=True)
def stop_all_actors() -> Iterator[None]:
    try:
        yield
    finally:
        stop_every_actor()


def robot(name: str, store: Store, intensity: int = 3) -> Any:
    """A robot supervisor with two skill actors."""
    spec = SupervisorSpec(intensity=intensity, period=30.0, backoff=FAST)
    skills = [actor_child(f"{name}.{s}", counter(store)) for s in ("goto", "scan")]
    return actor_child(name, nested(spec, skills), kind=ChildKind.SUPERVISOR)


def skill(sup: pykka.ActorRef[Any], robot_id: str, skill_id: str) -> Any:
    robot_ref = sup.proxy().ref_of(robot_id).get(timeout=5)
    assert robot_ref is not None, f"{robot_id} is down"
    ref = robot_ref.proxy().ref_of(skill_id).get(timeout=5)
    assert ref is not None, f"{skill_id} is down"
    return ref.proxy()


def crash_until_escalated(sup: pykka.ActorRef[Any], log: EventLog, skill_id: str) -> None:
    """Crash a skill of uav1 four times: its robot (intensity 3) escalates on the 4th."""
    for i in range(4):
        ref = wait_until(lambda: _try_skill(sup, "uav1", skill_id), timeout=5,
                         message=f"{skill_id} up")
        ref.actor_ref.tell(CrashNow())
        log.wait_for("exit", skill_id, count=i + 1)


def _try_skill(sup: pykka.ActorRef[Any], robot_id: str, skill_id: str) -> Any:
    try:
        return skill(sup, robot_id, skill_id)
    except (AssertionError, pykka.ActorDeadError):
        return None


def fleet(log: EventLog, store: Store, **flags: Any) -> pykka.ActorRef[ActorSupervisor]:
    flags.setdefault("backoff", FAST)
    spec = SupervisorSpec(**flags)
    return ActorSupervisor.start(spec, [robot("uav1", store), robot("ugv1", store)],
                                 name="robots", publish=log)


def test_actor_raising_in_nested_supervisor_restarts_only_that_actor_with_rebuilt_state() -> None:
    log, store = EventLog(), Store()
    sup = fleet(log, store)
    goto = skill(sup, "uav1", "uav1.goto")
    goto.add(7).get()
    goto.commit().get()
    with pytest.raises(ZeroDivisionError):
        goto.divide(0).get()
    assert skill(sup, "uav1", "uav1.goto").get().get() == (7, 2)
    assert skill(sup, "uav1", "uav1.scan").get().get() == (0, 1)
    assert skill(sup, "ugv1", "ugv1.goto").get().get() == (0, 1)
    (restart,) = log.of("restart")
    assert restart.child == "uav1.goto" and restart.supervisor == "robots/uav1"
    tree = sup.proxy().tree().get()
    assert [c.id for c in tree.children] == ["uav1", "ugv1"]
    node = tree.find("uav1.goto")
    assert node is not None and node.incarnation == 2 and node.restarts == 1
    assert tree.find("uav1").restarts == 0  # type: ignore[union-attr]


def test_nested_supervisor_escalates_and_parent_restarts_the_whole_robot() -> None:
    log, store = EventLog(), Store()
    sup = fleet(log, store)
    crash_until_escalated(sup, log, "uav1.scan")
    (esc,) = log.wait_for("escalate", "uav1.scan")
    assert esc.supervisor == "robots/uav1"
    (restart,) = log.wait_for("restart", "uav1")
    assert restart.supervisor == "robots" and restart.reason.startswith("escalated")
    goto = wait_until(lambda: _try_skill(sup, "uav1", "uav1.goto"), timeout=5)
    assert goto.get().get()[1] == 1  # a fresh robot supervisor starts fresh skills
    assert skill(sup, "ugv1", "ugv1.scan").get().get() == (0, 1)


def test_quarantine_of_one_robot_leaves_the_others_running() -> None:
    log, store = EventLog(), Store()
    sup = fleet(log, store, intensity=0, on_exceeded=OnExceeded.QUARANTINE, probation=60.0)
    crash_until_escalated(sup, log, "uav1.goto")
    (q,) = log.wait_for("quarantine", "uav1")
    assert q.detail["robot"] == "uav1" and q.supervisor == "robots"
    assert sup.proxy().ref_of("uav1").get() is None
    assert skill(sup, "ugv1", "ugv1.goto").add(2).get() == 2
    tree = sup.proxy().tree().get()
    assert tree.find("uav1").state == "quarantined"  # type: ignore[union-attr]
    assert tree.find("ugv1").state == "running"  # type: ignore[union-attr]
