"""Bids and their ranking, as pure functions: each named evaluator, the tie-break, the
fallback when a project's evaluator misbehaves, and why a task waits."""

from __future__ import annotations

import logging
import math

import pytest

from mrss.actors.rcl.allocation.bids import Bid, BidRequest, Work, compute_bid, fraction_done
from mrss.actors.rcl.allocation.evaluators import BidRanking, Evaluator
from mrss.actors.rcl.allocation.profile import RobotProfile
from mrss.actors.rcl.allocation.task import Task
from mrss.errors import ActionError
from mrss.messages import ActionRequest, WaitReason

TASK = Task("t1", "cover", frozenset({"camera"}), near=(48.0, 16.0), priority=2)

# a: near, low battery; b: far, full; c: far from the task but its way home passes it
A = Bid("a", finish_s=10, travel_m=100, home_m=5000, back_m=4900, battery=40,
        battery_after=30)
B = Bid("b", finish_s=50, travel_m=500, home_m=500, back_m=0, battery=95, battery_after=94)
C = Bid("c", finish_s=80, travel_m=800, home_m=300, back_m=1000, battery=70,
        battery_after=69)


@pytest.mark.parametrize(("evaluator", "winner"), [
    (Evaluator.QUICKEST_FINISH, "a"),   # 10 s
    (Evaluator.LEAST_COST, "b"),        # 1000 m there and home
    (Evaluator.LEAST_MARGINAL_COST, "c"),  # adds 100 m to its way home
    (Evaluator.BATTERY_AWARE, "b"),     # 94 % after
])
def test_each_evaluator_picks_its_best(evaluator: Evaluator, winner: str) -> None:
    choice = BidRanking(evaluator).choose(TASK, [C, A, B])
    assert choice.winner is not None and choice.winner.robot == winner
    assert choice.why.endswith(f"({evaluator.value})")


def test_ties_go_to_the_same_robot_whatever_the_order() -> None:
    twins = [Bid(r, finish_s=5.0, travel_m=25.0) for r in ("uav3", "uav1", "uav2")]
    for order in (twins, twins[::-1], twins[1:] + twins[:1]):
        assert BidRanking().choose(TASK, order).winner == twins[1]  # uav1


def test_an_idle_robot_goes_before_one_that_would_preempt() -> None:
    preempting = Bid("a", finish_s=1.0, travel_m=5.0, preempts=True, busy_priority=1)
    idle = Bid("b", finish_s=100.0, travel_m=500.0)
    assert BidRanking().choose(TASK, [preempting, idle]).winner == idle


@pytest.mark.parametrize("bad", [lambda t, b: "soon", lambda t, b: math.nan,
                                 lambda t, b: 1 / 0, lambda t, b: None])
def test_a_misbehaving_evaluator_gives_way_to_the_default_logged_once(
        bad: object, caplog: pytest.LogCaptureFixture) -> None:
    ranking = BidRanking(bad)  # type: ignore[arg-type]
    with caplog.at_level(logging.WARNING, logger="mrss.rcl.allocation"):
        for _ in range(5):
            assert ranking.choose(TASK, [B, A, C]).winner == A  # quickest finish
    assert len([r for r in caplog.records if "decides instead" in r.getMessage()]) == 1
    assert ranking.faults.total == 5


def test_a_project_evaluator_is_used() -> None:
    def most_travel(task: Task, bid: Bid) -> float:
        return -bid.travel_m
    assert BidRanking(most_travel).choose(TASK, [A, B, C]).winner == C


def test_a_task_with_no_fit_bid_waits_for_the_best_excuse() -> None:
    busy = Bid("a", unfit=WaitReason.BUSY, note="busy with priority 5")
    down = Bid("b", unfit=WaitReason.UNAVAILABLE, note="unavailable: link down")
    choice = BidRanking().choose(TASK, [down, busy])
    assert choice.winner is None and choice.wait is WaitReason.BUSY
    assert choice.why == "a busy with priority 5; b unavailable: link down"
    assert BidRanking().choose(TASK, []).wait is WaitReason.NO_BID


def _bid(battery: float | None = 80.0, work: tuple[Work, ...] = (),
         teleop: bool = False, position: tuple[float, float] | None = (48.01, 16.0)) -> Bid:
    profile = RobotProfile("uav1", frozenset({"camera"}), cruise_speed=10.0,
                           battery_per_km=2.0, battery_reserve=20.0)
    return compute_bid(BidRequest(TASK, profile, base=(48.02, 16.0)), position=position,
                       battery=battery, teleop=teleop, work=list(work))


def test_a_bid_from_the_robots_own_state() -> None:
    bid = _bid()
    assert bid.fit and round(bid.travel_m) == 1112 and round(bid.home_m) == 2224
    assert bid.finish_s == pytest.approx(bid.travel_m / 10.0)
    assert bid.battery_after == pytest.approx(80.0 - 2.0 * (bid.travel_m + bid.home_m) / 1000)
    assert _bid(battery=25.0).unfit is WaitReason.BATTERY  # 25 - 6.7 < 20
    assert _bid(battery=None).fit and _bid(battery=None).battery_after is None
    assert _bid(teleop=True).unfit is WaitReason.UNAVAILABLE
    assert math.isinf(_bid(position=None).finish_s)


def test_work_of_lower_priority_is_preempted_equal_or_higher_keeps_the_robot_busy() -> None:
    low = _bid(work=(Work("x", 1, 0.5),))
    assert low.fit and low.preempts and low.busy_priority == 1
    same = _bid(work=(Work("x", 2, 0.25),))
    assert same.unfit is WaitReason.BUSY and same.note == "busy with priority 2 (25% done)"
    assert fraction_done({"waypoint": 3, "waypoints": 12}) == 0.25
    assert fraction_done({"phase": "x"}) == 0.0


@pytest.mark.parametrize(("role", "problem"), [
    ({"capabilities": []}, "non-empty list"),
    ({"capabilities": ["camera"], "near": [95, 0]}, "[lat, lon]"),
    ({"capabilities": ["camera"], "where": 1}, "not where"),
])
def test_a_malformed_role_is_refused(role: dict[str, object], problem: str) -> None:
    with pytest.raises(ActionError, match=problem.replace("[", r"\[").replace("]", r"\]")):
        Task.of(ActionRequest(uuid="u", name="cover", args=[], role=role))
