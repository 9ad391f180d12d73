"""Actor supervision with real pykka actors: restarts, strategies, watchdog, quarantine."""

from __future__ import annotations

from collections.abc import Iterator
from typing import Any

import pykka
import pytest

from mrss.errors import SupervisionError
from mrss.supervision.actors import ActorSupervisor, BlockFor, CrashNow, actor_child
from mrss.supervision.events import EventLog
from mrss.supervision.reason import Cause, ExitReason
from mrss.supervision.spec import Backoff, OnExceeded, Restart, Strategy, SupervisorSpec
from mrss.testing import wait_until
from tests.projects.actorkit import Counter, Store, counter, stop_every_actor

NO_BACKOFF = Backoff(initial=0.0)


@pytest.fixture(autouse=True)
def stop_all_actors() -> Iterator[None]:
    try:
        yield
    finally:
        stop_every_actor()


@pytest.fixture()
def log() -> EventLog:
    return EventLog()


def start(
    log: EventLog, *ids: str, store: Store | None = None, strategy: Strategy = Strategy.ONE_FOR_ONE,
    on_give_up: Any = None, restart: dict[str, Restart] | None = None, **flags: Any,
) -> tuple[pykka.ActorRef[ActorSupervisor], Store]:
    store = store or Store()
    restart = restart or {}
    flags.setdefault("backoff", NO_BACKOFF)
    spec = SupervisorSpec(strategy=strategy, **flags)
    kids = [actor_child(i, counter(store), restart=restart.get(i, Restart.PERMANENT))
            for i in ids]
    ref = ActorSupervisor.start(spec, kids, name="sup", publish=log, on_give_up=on_give_up)
    return ref, store


def child(sup: pykka.ActorRef[ActorSupervisor], cid: str) -> Any:
    ref = sup.proxy().ref_of(cid).get(timeout=5)
    assert ref is not None, f"{cid} is down"
    return ref.proxy()


def incarnation(sup: pykka.ActorRef[ActorSupervisor], cid: str) -> int:
    ref = sup.proxy().ref_of(cid).get(timeout=5)
    return 0 if ref is None else int(ref.proxy().get().get(timeout=5)[1])


def test_crash_in_ask_handler_restarts_actor_with_state_rebuilt_by_setup(log: EventLog) -> None:
    sup, store = start(log, "a")
    a = child(sup, "a")
    a.add(5).get()
    a.commit().get()
    a.add(100).get()  # not committed: lost with the incarnation
    with pytest.raises(ZeroDivisionError):
        a.divide(0).get()
    assert child(sup, "a").get().get() == (5, 2)
    (restart,) = log.of("restart", "a")
    assert restart.count == 1 and restart.reason.startswith("crashed: ZeroDivisionError")
    assert "teardown a 1" in store.trace


def test_crash_in_tell_handler_restarts_actor(log: EventLog) -> None:
    sup, _ = start(log, "a")
    child(sup, "a").actor_ref.tell(CrashNow("boom"))
    log.wait_for("start", "a", count=2)
    assert incarnation(sup, "a") == 2
    assert log.of("exit", "a")[0].reason == "crashed: InjectedFault: boom"


def test_caller_error_is_returned_and_the_actor_survives(log: EventLog) -> None:
    sup, _ = start(log, "a")
    with pytest.raises(KeyError):
        child(sup, "a").lookup("missing").get()
    assert incarnation(sup, "a") == 1
    assert log.of("exit") == []


def test_one_for_all_restarts_every_actor(log: EventLog) -> None:
    sup, _ = start(log, "a", "b", "c", strategy=Strategy.ONE_FOR_ALL)
    with pytest.raises(ZeroDivisionError):
        child(sup, "b").divide(0).get()
    assert [incarnation(sup, c) for c in "abc"] == [2, 2, 2]
    stops = [e.child for e in log.of("exit") if e.reason.startswith("shutdown")]
    assert stops == ["c", "a"]


def test_rest_for_one_restarts_later_actors_only(log: EventLog) -> None:
    sup, _ = start(log, "a", "b", "c", strategy=Strategy.REST_FOR_ONE)
    with pytest.raises(ZeroDivisionError):
        child(sup, "b").divide(0).get()
    assert [incarnation(sup, c) for c in "abc"] == [1, 2, 2]


def test_transient_actor_that_stops_itself_is_not_restarted(log: EventLog) -> None:
    sup, _ = start(log, "a", restart={"a": Restart.TRANSIENT})
    child(sup, "a").finish().get()
    wait_until(lambda: sup.proxy().ref_of("a").get() is None, timeout=5)
    (exit_,) = log.wait_for("exit", "a")
    assert exit_.reason == "normal: stopped itself"
    assert log.of("restart") == []


def test_start_hook_failure_counts_and_root_gives_up(log: EventLog) -> None:
    reasons: list[ExitReason] = []
    store = Store(fail_setup={"a"})
    sup, _ = start(log, "a", store=store, intensity=2, period=10.0, on_give_up=reasons.append)
    log.wait_for("give_up", "a")
    assert len(log.of("restart", "a")) == 2
    wait_until(lambda: not sup.is_alive(), timeout=5, message="root supervisor stopped")
    assert reasons and reasons[0].cause is Cause.ESCALATED
    assert "child a" in reasons[0].detail and "more than 2 restarts" in reasons[0].detail


def test_watchdog_replaces_an_actor_blocked_past_its_limit(log: EventLog) -> None:
    store = Store()
    spec = SupervisorSpec(backoff=NO_BACKOFF)
    # 1 s: no ordinary handler on a loaded machine is taken for hung; the block is 3x it
    kid = actor_child("slow", counter(store), watchdog=1.0)
    sup = ActorSupervisor.start(spec, [kid], name="sup", publish=log)
    child(sup, "slow").actor_ref.tell(BlockFor(3.0))
    (exit_,) = log.wait_for("exit", "slow", timeout=10)
    assert exit_.reason.startswith("hung: handler blocked")
    log.wait_for("start", "slow", count=2)
    assert child(sup, "slow").add(1).get(timeout=10) == 1


def test_link_down_is_a_distinct_reason_that_does_not_exhaust_intensity(log: EventLog) -> None:
    sup, _ = start(log, "uav1", intensity=1, period=30.0)
    for _ in range(3):
        with pytest.raises(Exception, match="no heartbeat"):
            child(sup, "uav1").lose_link("no heartbeat").get()
    assert incarnation(sup, "uav1") == 4
    reasons = [e.reason for e in log.of("exit", "uav1")]
    assert reasons == ["link_down: no heartbeat"] * 3
    assert log.of("give_up") == []


def test_quarantine_stops_only_the_bad_robot_and_releases_it_after_probation(
        log: EventLog) -> None:
    sup, _ = start(log, "uav1", "ugv1", intensity=1, period=30.0,
                   on_exceeded=OnExceeded.QUARANTINE, probation=3.0)  # the checks come
    for _ in range(2):
        with pytest.raises(ZeroDivisionError):
            child(sup, "uav1").divide(0).get()
    (q,) = log.wait_for("quarantine", "uav1")
    assert q.detail["robot"] == "uav1"
    assert sup.proxy().ref_of("uav1").get() is None
    assert child(sup, "ugv1").add(1).get() == 1
    tree = sup.proxy().tree().get()
    assert tree.find("uav1").state == "quarantined"  # type: ignore[union-attr]
    log.wait_for("release", "uav1", timeout=30)
    assert incarnation(sup, "uav1") == 3
    assert log.of("give_up") == []


def test_stopping_the_supervisor_stops_children_in_reverse_order(log: EventLog) -> None:
    sup, store = start(log, "a", "b", "c")
    sup.stop(block=True, timeout=5)
    assert [t for t in store.trace if t.startswith("teardown")] == [
        "teardown c 1", "teardown b 1", "teardown a 1"]
    assert [t for t in store.trace if t.startswith("setup")] == [
        "setup a 1", "setup b 1", "setup c 1"]


def test_shutdown_kill_abandons_a_blocked_child_at_once(log: EventLog) -> None:
    store = Store()
    spec = SupervisorSpec()
    sup = ActorSupervisor.start(spec, [actor_child("a", counter(store), shutdown="kill")],
                                name="sup", publish=log)
    child(sup, "a").actor_ref.tell(BlockFor(10.0))
    sup.stop(block=True, timeout=5)  # well before the block ends: abandoned at once
    (exit_,) = log.of("exit", "a")
    assert exit_.reason == "shutdown: killed (shutdown = kill)"


def test_dynamic_children_and_bad_requests_do_not_kill_the_supervisor(log: EventLog) -> None:
    sup, store = start(log, "a")
    proxy = sup.proxy()
    ref = proxy.add_child(actor_child("b", counter(store))).get()
    assert ref is not None and ref.proxy().add(2).get() == 2
    with pytest.raises(SupervisionError, match="duplicate"):
        proxy.add_child(actor_child("b", counter(store))).get()
    with pytest.raises(SupervisionError, match="no child"):
        proxy.remove_child("zz").get()
    proxy.remove_child("b").get()
    assert proxy.which_children().get() == ["a"]
    assert sup.is_alive()


def test_factory_must_start_a_supervised_actor(log: EventLog) -> None:
    class Plain(pykka.ThreadingActor):
        pass

    spec = SupervisorSpec(intensity=0)
    reasons: list[ExitReason] = []
    ActorSupervisor.start(spec, [actor_child("p", lambda ctx: Plain.start())], name="sup",
                          publish=log, on_give_up=reasons.append)
    (exit_,) = log.wait_for("exit", "p")
    assert "must start a SupervisedActor" in exit_.reason


def test_counter_is_usable_standalone() -> None:
    ref = Counter.start(None, Store())  # type: ignore[arg-type]
    assert ref.proxy().add(3).get() == 3
    ref.stop()
