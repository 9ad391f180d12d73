"""One round over the fleet's state (FleetRound) chooses what ranking every robot's whole
bid chooses: same winner, same reason, same wait, the same bids published, for each
named evaluator, over random fleets of idle, busy, pre-emptable, low-battery, teleop,
unavailable and silent robots."""

from __future__ import annotations

import random

import pytest

from mrss.actors.rcl.allocation.bids import Bid, Place, Work
from mrss.actors.rcl.allocation.board import BidState
from mrss.actors.rcl.allocation.evaluators import BidRanking, Choice, Evaluator
from mrss.actors.rcl.allocation.fleet import FleetRound
from mrss.actors.rcl.allocation.profile import RobotProfile
from mrss.actors.rcl.allocation.task import Task
from mrss.messages import WaitReason


def _fleet(rng: random.Random, size: int) -> tuple[list[RobotProfile], dict[str, str],
                                                   dict[str, BidState],
                                                   dict[str, tuple[Place | None, float | None]]]:
    profiles, unavailable, states, where = [], {}, {}, {}
    for k in range(size):
        robot = f"r{k:03d}"
        profiles.append(RobotProfile(
            robot, frozenset({"camera"}), cruise_speed=rng.choice([3.0, 5.0, 12.0]),
            battery_per_km=rng.choice([0.0, 1.0, 40.0]),
            base=rng.choice([None, (48.0 + rng.random() / 100, 16.0)])))
        kind = rng.random()
        if kind < 0.1:
            unavailable[robot] = "link down: no heartbeat"
        if kind > 0.05:  # else: no actor has published (down, not set up yet)
            work = tuple(Work(f"w{k}{j}", rng.randint(0, 4), rng.random())
                         for j in range(rng.choice([0, 0, 0, 1, 2])))
            states[robot] = BidState(teleop=rng.random() < 0.05, work=work)
        position = None if rng.random() < 0.05 else (48.0 + rng.random() / 50,
                                                     16.0 + rng.random() / 50)
        where[robot] = (position, None if rng.random() < 0.2 else rng.uniform(10, 100))
    return profiles, unavailable, states, where


def _said(choice: Choice) -> tuple[str | None, WaitReason, str, list[str], int]:
    """What a choice says and publishes: its winner, wait, reason, the bids it lists (by
    robot, in rank order) and how many robots bid."""
    return (choice.winner.robot if choice.winner else None, choice.wait, choice.why,
            [b.robot for b in choice.bids], choice.bidders)


def _every_bid(task: Task, profiles: list[RobotProfile], fleet: FleetRound) -> list[Bid]:
    return [fleet.bid(task, p) for p in profiles]


@pytest.mark.parametrize("evaluator", list(Evaluator))
def test_one_pass_chooses_as_ranking_every_whole_bid(evaluator: Evaluator) -> None:
    rng = random.Random(evaluator.value)
    ranking = BidRanking(evaluator)
    outcomes = set()
    for trial in range(300):
        profiles, unavailable, states, where = _fleet(rng, rng.choice([1, 3, 10, 60]))
        task = Task(f"t{trial}", "goto", frozenset({"camera"}),
                    near=None if rng.random() < 0.1 else (48.01, 16.01),
                    priority=rng.randint(0, 5))
        fast = FleetRound(unavailable, states, where.__getitem__, {})
        slow = FleetRound(unavailable, states, where.__getitem__, {})
        got = fast.choose(task, profiles, ranking)
        expected = ranking.choose(task, _every_bid(task, profiles, slow))
        assert _said(got) == _said(expected), trial  # whole bids: NaN figures never equal
        outcomes.add(got.wait)
    assert outcomes >= {WaitReason.NONE, WaitReason.BUSY}  # both paths were taken


def test_one_pass_reads_each_robots_link_once_and_keeps_first_seen_bases() -> None:
    reads: list[str] = []

    def where(robot: str) -> tuple[Place | None, float | None]:
        reads.append(robot)
        return (48.0, 16.0 + int(robot[1:]) / 1000), 90.0

    profiles = [RobotProfile(f"r{k}", frozenset({"camera"})) for k in range(1, 6)]
    bases: dict[str, Place] = {}
    fleet = FleetRound({}, {p.robot: BidState() for p in profiles}, where, bases)
    choice = fleet.choose(Task("t", "goto", frozenset({"camera"}), near=(48.0, 16.0)),
                          profiles, BidRanking())
    assert choice.winner is not None and choice.winner.robot == "r1"
    assert sorted(reads) == [p.robot for p in profiles]  # once each, winner included
    assert bases == {p.robot: (48.0, 16.0 + k / 1000) for k, p in enumerate(profiles, 1)}


def test_a_project_evaluator_is_given_every_whole_bid() -> None:
    seen: list[str] = []

    def farthest(task: Task, bid: Bid) -> float:
        seen.append(bid.robot)
        return -bid.travel_m

    profiles = [RobotProfile(f"r{k}", frozenset({"camera"})) for k in range(1, 4)]
    fleet = FleetRound({"r2": "quarantined"}, {p.robot: BidState() for p in profiles},
                       lambda r: ((48.0, 16.0 + int(r[1:]) / 100), None), {})
    choice = fleet.choose(Task("t", "goto", frozenset({"camera"}), near=(48.0, 16.0)),
                          profiles, BidRanking(farthest))
    assert choice.winner is not None and choice.winner.robot == "r3"
    assert sorted(seen) == ["r1", "r3"]  # the fit ones, as whole bids
    assert "r2 unavailable: quarantined" in choice.why
