"""The restart rule book, driven by a fake clock (no processes, no threads)."""

from __future__ import annotations

import pytest

from mrss.errors import SupervisionError
from mrss.supervision.policy import Action, RestartIntensity, RestartPolicy
from mrss.supervision.reason import Cause, ExitReason
from mrss.supervision.spec import (
    Backoff,
    ChildKind,
    ChildSpec,
    OnExceeded,
    Restart,
    Strategy,
    SupervisorSpec,
)

CRASH = ExitReason(Cause.CRASHED, "ValueError: boom")
NORMAL = ExitReason(Cause.NORMAL, "exit code 0")
LINK = ExitReason(Cause.LINK_DOWN, "no heartbeat from uav1")


class FakeClock:
    def __init__(self) -> None:
        self.now = 1000.0

    def __call__(self) -> float:
        return self.now


def children(*specs: tuple[str, Restart]) -> list[ChildSpec[None]]:
    return [ChildSpec(cid, None, restart=r) for cid, r in specs]


def policy(
    strategy: Strategy = Strategy.ONE_FOR_ONE, *, restart: dict[str, Restart] | None = None,
    clock: FakeClock | None = None, **flags: object,
) -> RestartPolicy:
    restart = restart or {}
    kids = children(*[(c, restart.get(c, Restart.PERMANENT)) for c in "abcd"])
    spec = SupervisorSpec(strategy=strategy, backoff=Backoff(jitter=0.0), **flags)  # type: ignore[arg-type]
    p = RestartPolicy(spec, kids, clock=clock or FakeClock(), rand=lambda: 0.5)
    for c in p.order:
        p.child_started(c)
    return p


def test_one_for_one_restarts_only_the_failed_child() -> None:
    d = policy().child_exited("b", CRASH, running={"a", "c", "d"})
    assert d.action is Action.RESTART
    assert d.restart == ("b",) and d.stop == ()
    assert d.count == 1


def test_one_for_all_stops_siblings_in_reverse_order_and_restarts_all_in_order() -> None:
    d = policy(Strategy.ONE_FOR_ALL).child_exited("b", CRASH, running={"a", "c", "d"})
    assert d.stop == ("d", "c", "a")
    assert d.restart == ("a", "b", "c", "d")


def test_rest_for_one_restarts_the_child_and_later_siblings() -> None:
    d = policy(Strategy.REST_FOR_ONE).child_exited("b", CRASH, running={"a", "c", "d"})
    assert d.stop == ("d", "c")
    assert d.restart == ("b", "c", "d")


def test_temporary_sibling_stopped_by_one_for_all_is_not_started_again() -> None:
    p = policy(Strategy.ONE_FOR_ALL, restart={"c": Restart.TEMPORARY})
    d = p.child_exited("a", CRASH, running={"b", "c", "d"})
    assert d.stop == ("d", "c", "b")
    assert d.restart == ("a", "b", "d")
    assert d.drop == ("c",)
    assert not p.active("c")


def test_temporary_child_is_never_restarted() -> None:
    p = policy(restart={"a": Restart.TEMPORARY})
    d = p.child_exited("a", CRASH, running={"b"})
    assert d.action is Action.LEAVE and d.restart == ()
    assert not p.active("a")


def test_transient_child_restarts_only_after_abnormal_exit() -> None:
    p = policy(Strategy.ONE_FOR_ALL, restart={"a": Restart.TRANSIENT})
    assert p.child_exited("a", NORMAL, running={"b"}).action is Action.LEAVE
    p.child_started("a")
    assert p.child_exited("a", CRASH, running={"b"}).action is Action.RESTART


def test_finished_transient_child_is_not_restarted_by_a_sibling_failure() -> None:
    p = policy(Strategy.ONE_FOR_ALL, restart={"a": Restart.TRANSIENT})
    p.child_exited("a", NORMAL, running={"b", "c", "d"})
    d = p.child_exited("c", CRASH, running={"b", "d"})
    assert d.restart == ("b", "c", "d")


def test_intensity_exceeded_escalates_and_stops_everything_in_reverse_order() -> None:
    p = policy(intensity=2, period=10.0)
    for _ in range(2):
        assert p.child_exited("b", CRASH, running={"a", "c"}).action is Action.RESTART
        p.child_started("b")
    d = p.child_exited("b", CRASH, running={"a", "c"})
    assert d.action is Action.ESCALATE
    assert d.stop == ("c", "a")
    assert "more than 2 restarts in 10s" in d.note
    assert not any(p.active(c) for c in p.order)


def test_restarts_older_than_the_period_are_forgotten() -> None:
    clock = FakeClock()
    p = policy(intensity=1, period=5.0, clock=clock)
    assert p.child_exited("a", CRASH).action is Action.RESTART
    clock.now += 5.0
    assert p.child_exited("a", CRASH).action is Action.RESTART
    clock.now += 1.0
    assert p.child_exited("a", CRASH).action is Action.ESCALATE


def test_intensity_zero_never_restarts() -> None:
    assert policy(intensity=0).child_exited("a", CRASH).action is Action.ESCALATE


def test_link_down_does_not_count_toward_intensity() -> None:
    p = policy(intensity=1)
    for _ in range(5):
        d = p.child_exited("a", LINK)
        assert d.action is Action.RESTART
    assert p.child_exited("a", CRASH).action is Action.RESTART
    assert p.child_exited("a", CRASH).action is Action.ESCALATE


def test_backoff_grows_with_the_streak_up_to_the_cap() -> None:
    clock = FakeClock()
    spec = SupervisorSpec(intensity=100, period=1.0,
                          backoff=Backoff(initial=0.1, factor=2.0, cap=0.5, jitter=0.0))
    p = RestartPolicy(spec, children(("a", Restart.PERMANENT)), clock=clock, rand=lambda: 0.0)
    delays = []
    for _ in range(6):
        p.child_started("a")
        clock.now += 0.01
        delays.append(p.child_exited("a", CRASH).delay)
    assert delays == pytest.approx([0.0, 0.1, 0.2, 0.4, 0.5, 0.5])


def test_streak_is_forgotten_after_a_healthy_run() -> None:
    clock = FakeClock()
    p = policy(intensity=100, healthy_after=30.0, clock=clock)
    for _ in range(3):
        p.child_started("a")
        p.child_exited("a", CRASH)
    assert p.streak("a") == 3
    p.child_started("a")
    clock.now += 31.0
    d = p.child_exited("a", CRASH)
    assert p.streak("a") == 1 and d.delay == 0.0
    assert p.restarts("a") == 4


def test_jitter_spreads_delays_within_bounds() -> None:
    b = Backoff(initial=1.0, factor=2.0, cap=10.0, jitter=0.25)
    assert b.delay(3, 0.0) == pytest.approx(1.5)
    assert b.delay(3, 0.999999) == pytest.approx(2.5, abs=1e-4)
    assert b.delay(1, 0.0) == 0.0


def test_quarantine_takes_only_the_offending_child_out_and_release_restores_it() -> None:
    p = policy(intensity=1, on_exceeded=OnExceeded.QUARANTINE, probation=20.0)
    assert p.child_exited("a", CRASH).action is Action.RESTART
    assert p.child_exited("b", CRASH).action is Action.RESTART  # per-child windows
    d = p.child_exited("a", CRASH, running={"b", "c"})
    assert d.action is Action.QUARANTINE and d.delay == 20.0 and d.stop == ()
    assert not p.active("a") and p.active("b")
    p.release("a")
    assert p.active("a") and p.streak("a") == 0
    assert p.child_exited("a", CRASH).action is Action.RESTART


def test_quarantine_requires_one_for_one() -> None:
    with pytest.raises(SupervisionError, match="quarantine"):
        SupervisorSpec(strategy=Strategy.ONE_FOR_ALL, on_exceeded=OnExceeded.QUARANTINE)


def test_intensity_window_counts_only_within_period() -> None:
    w = RestartIntensity(2, 1.0)
    assert w.add(0.0) and w.add(0.5)
    assert not w.add(0.9)
    assert w.add(2.0)
    assert len(w) == 1


@pytest.mark.parametrize(("kwargs", "match"), [
    ({"id": ""}, "child id"),
    ({"id": "x", "restart": "sometimes"}, "restart must be one of"),
    ({"id": "x", "shutdown": -1}, "shutdown"),
    ({"id": "x", "shutdown": "later"}, "shutdown"),
    ({"id": "x", "kind": "manager"}, "kind"),
])
def test_bad_child_specs_are_rejected_with_the_field(kwargs: dict[str, object], match: str) -> None:
    with pytest.raises(SupervisionError, match=match):
        ChildSpec(start=None, **kwargs)  # type: ignore[arg-type]


def test_child_spec_coerces_strings_to_enums() -> None:
    spec = ChildSpec("x", None, restart="transient", kind="supervisor", shutdown="kill")  # type: ignore[arg-type]
    assert spec.restart is Restart.TRANSIENT and spec.kind is ChildKind.SUPERVISOR
    assert spec.shutdown_timeout == 0.0


@pytest.mark.parametrize(("kwargs", "match"), [
    ({"intensity": -1}, "intensity"),
    ({"period": 0}, "period"),
    ({"strategy": "all_for_none"}, "strategy"),
])
def test_bad_supervisor_specs_are_rejected(kwargs: dict[str, object], match: str) -> None:
    with pytest.raises(SupervisionError, match=match):
        SupervisorSpec(**kwargs)  # type: ignore[arg-type]


@pytest.mark.parametrize(("kwargs", "match"), [
    ({"factor": 0.5}, "factor"), ({"jitter": 1.5}, "jitter"), ({"cap": -1.0}, "cap"),
])
def test_bad_backoffs_are_rejected(kwargs: dict[str, float], match: str) -> None:
    with pytest.raises(SupervisionError, match=match):
        Backoff(**kwargs)


def test_duplicate_and_unknown_children_are_errors() -> None:
    p = policy()
    with pytest.raises(SupervisionError, match="duplicate"):
        p.add_child(ChildSpec("a", None))
    with pytest.raises(SupervisionError, match="no child"):
        p.child_exited("zz", CRASH)
