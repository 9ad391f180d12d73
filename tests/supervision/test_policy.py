"""The restart rule book, driven by a fake clock (no processes, no threads)."""

from __future__ import annotations

import math

import pytest

from mrss.errors import SupervisionError
from mrss.supervision.policy import Action, RestartIntensity, RestartPolicy
from mrss.supervision.reason import Cause, ExitReason
from mrss.supervision.spec import (
    Backoff,
    ChildKind,
    ChildSpec,
    Group,
    OnExceeded,
    Restart,
    Strategy,
    SupervisorSpec,
)

CRASH = ExitReason(Cause.CRASHED, "ValueError: boom")
NORMAL = ExitReason(Cause.NORMAL, "exit code 0")
LINK = ExitReason(Cause.LINK_DOWN, "no heartbeat from uav1")
KILL = ExitReason(Cause.KILLED, "SIGKILL")


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
    assert "more than 2 restarts of b in 10s" in d.note
    assert not any(p.active(c) for c in p.order)


def test_a_siblings_restarts_never_use_up_a_childs_budget() -> None:
    p = policy(intensity=2, period=30.0)
    for _ in range(2):
        for c in "abcd":  # eight restarts in all, two each
            assert p.child_exited(c, CRASH).action is Action.RESTART
    assert p.child_exited("a", CRASH).action is Action.ESCALATE  # a's third


def test_six_kills_of_five_components_in_26s_with_the_shipped_budget_restart_them_all() -> None:
    """Finding 5 of issue 9: the shipped 5 in 30 s was shared by all nine children."""
    clock = FakeClock()
    kids = [ChildSpec(c, None) for c in ("bus", "broker", "worldmodel", "datalayer", "events",
                                         "sim_uav", "sim_ugv", "rcl", "reasoner")]
    p = RestartPolicy(SupervisorSpec(intensity=5, period=30.0, backoff=Backoff(jitter=0.0)),
                      kids, clock=clock)
    for at, child in ((0, "rcl"), (4, "bus"), (9, "reasoner"), (14, "worldmodel"),
                      (20, "rcl"), (26, "events")):
        clock.now = 1000.0 + at
        p.child_started(child)
        assert p.child_exited(child, KILL).action is Action.RESTART


def test_a_childs_budget_counts_its_restarts_within_the_window_only() -> None:
    clock = FakeClock()
    p = policy(intensity=3, period=30.0, clock=clock)
    assert p.budget("a", clock.now) == (0, 3, 30.0)
    for at in (0.0, 10.0, 20.0):
        clock.now = 1000.0 + at
        p.child_exited("a", CRASH)
    p.child_exited("b", CRASH)
    assert p.budget("a", clock.now) == (3, 3, 30.0)
    assert p.budget("b", clock.now) == (1, 3, 30.0)  # a sibling's are not its own
    assert p.budget("a", 1000.0 + 45.0) == (1, 3, 30.0)  # two left the window


def test_the_opt_in_shared_window_escalates_whatever_on_exceeded_says() -> None:
    p = policy(intensity=5, shared_intensity=2, on_exceeded=OnExceeded.QUARANTINE)
    assert p.child_exited("a", CRASH).action is Action.RESTART
    assert p.child_exited("b", CRASH).action is Action.RESTART
    d = p.child_exited("c", CRASH, running={"a", "b", "d"})
    assert d.action is Action.ESCALATE and "more than 2 restarts of all children" in d.note


def grouped(clock: FakeClock | None = None, **flags: object) -> RestartPolicy:
    """Children a b c d; a and b are the group "infra", c and d are in none."""
    return policy(intensity=1, period=30.0, groups=(Group("infra", ("a", "b")),),
                  clock=clock, **flags)


def test_a_child_over_its_budget_restarts_its_whole_group_and_nothing_else() -> None:
    p = grouped()
    assert p.child_exited("b", CRASH, running={"a", "c", "d"}).action is Action.RESTART
    p.child_started("b")
    d = p.child_exited("b", CRASH, running={"a", "c", "d"})
    assert d.action is Action.RESTART and d.group == "infra"
    assert d.stop == ("a",) and d.restart == ("a", "b") and d.delay == 0.0
    assert d.note == "more than 1 restarts of b in 30s: group infra restarts as a whole"
    # the restarted group starts with fresh budgets: b may fail once more on its own
    for c in "ab":
        p.child_started(c)
    assert p.child_exited("b", CRASH, running={"a"}).action is Action.RESTART
    assert p.group_of("a") == "infra" and p.group_of("c") == ""


def test_a_group_over_its_window_is_given_up_as_one_and_the_rest_runs_on() -> None:
    p = grouped(on_exceeded=OnExceeded.QUARANTINE, probation=math.inf)
    decisions = []
    for _ in range(4):  # b alone, group, b alone, group over its window
        decisions.append(p.child_exited("b", CRASH, running={"a", "c", "d"}))
        for c in decisions[-1].restart:
            p.child_started(c)
    assert [d.action for d in decisions] == [Action.RESTART] * 3 + [Action.QUARANTINE]
    d = decisions[-1]
    assert d.group == "infra" and d.drop == ("a", "b") and d.stop == ("a",)
    assert d.delay == math.inf and "restarts of group infra" in d.note
    assert not p.active("a") and not p.active("b") and p.active("c") and p.active("d")
    # ungrouped children keep their own budgets meanwhile
    assert p.child_exited("c", CRASH).action is Action.RESTART
    p.release("a")
    p.release("b")
    assert p.active("a") and p.child_exited("b", CRASH).action is Action.RESTART


def test_a_group_over_its_window_escalates_when_told_to() -> None:
    p = grouped()
    for _ in range(3):
        p.child_exited("a", CRASH, running={"b", "c", "d"})
        for c in "ab":
            p.child_started(c)
    d = p.child_exited("a", CRASH, running={"b", "c", "d"})
    assert d.action is Action.ESCALATE and d.stop == ("d", "c", "b")


def test_an_ungrouped_child_over_its_budget_is_given_up_alone() -> None:
    p = grouped(on_exceeded=OnExceeded.QUARANTINE, probation=60.0)
    p.child_exited("c", CRASH)
    d = p.child_exited("c", CRASH, running={"a", "b", "d"})
    assert d.action is Action.QUARANTINE and d.drop == ("c",) and d.stop == () and d.group == ""


def test_a_child_without_backoff_restarts_at_once_however_long_its_streak() -> None:
    clock = FakeClock()
    spec = SupervisorSpec(intensity=100, period=1.0, backoff=Backoff(jitter=0.0))
    p = RestartPolicy(spec, [ChildSpec("bus", None, backoff=False), ChildSpec("x", None)],
                      clock=clock, rand=lambda: 0.5)
    delays = {"bus": [], "x": []}  # type: dict[str, list[float]]
    for _ in range(5):
        for c in ("bus", "x"):
            p.child_started(c)  # and dies at once
            delays[c].append(p.child_exited(c, KILL).delay)
    assert delays["bus"] == [0.0] * 5 and p.streak("bus") == 5
    assert delays["x"] == pytest.approx([0.0, 0.1, 0.2, 0.4, 0.8])


def test_a_child_killed_every_15s_restarts_at_once_with_the_default_flags() -> None:
    """Repeated outside faults, not a crash loop: each run outlasted healthy_after (10 s)."""
    clock = FakeClock()
    p = RestartPolicy(SupervisorSpec(intensity=100, period=30.0), [ChildSpec("r", None)],
                      clock=clock)
    for _ in range(10):
        p.child_started("r")
        clock.now += 15.0
        assert p.child_exited("r", KILL).delay == 0.0


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
        p.child_started("a")  # and crashes at once
        delays.append(p.child_exited("a", CRASH).delay)
    assert delays == pytest.approx([0.0, 0.1, 0.2, 0.4, 0.5, 0.5])


def test_the_time_a_child_ran_counts_toward_its_backoff_delay() -> None:
    """Backoff spaces the starts of a crash loop: a run as long as the delay is spacing."""
    clock = FakeClock()
    spec = SupervisorSpec(intensity=100, period=60.0, healthy_after=30.0,
                          backoff=Backoff(initial=1.0, factor=2.0, cap=8.0, jitter=0.0))
    p = RestartPolicy(spec, children(("a", Restart.PERMANENT)), clock=clock, rand=lambda: 0.0)
    delays = []
    for ran in (0.0, 0.0, 1.5, 5.0, 0.0):  # streaks 1..5: 0, 1, 2, 4, 8 s of backoff
        p.child_started("a")
        clock.now += ran
        delays.append(p.child_exited("a", KILL).delay)
    assert delays == pytest.approx([0.0, 1.0, 0.5, 0.0, 8.0])
    assert p.streak("a") == 5  # none of these runs was healthy (30 s)


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


def test_a_quarantined_child_is_left_out_of_its_siblings_one_for_all_restarts() -> None:
    p = policy(Strategy.ONE_FOR_ALL, intensity=0, on_exceeded=OnExceeded.QUARANTINE)
    assert p.child_exited("b", CRASH, running={"a", "c", "d"}).action is Action.QUARANTINE
    d = p.child_exited("c", LINK, running={"a", "d"})  # a lost link: not counted
    assert d.action is Action.RESTART
    assert d.stop == ("d", "a") and d.restart == ("a", "c", "d")


def test_groups_need_one_for_one() -> None:
    with pytest.raises(SupervisionError, match="groups need strategy 'one_for_one'"):
        SupervisorSpec(strategy=Strategy.ONE_FOR_ALL, groups=(Group("g", ("a",)),))


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
