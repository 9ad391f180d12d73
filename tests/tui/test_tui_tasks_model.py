"""The dashboard's tasks addressed to a role (`models/tasks.py`): why a robot holds one,
from the bids published; what a waiting one waits for; each hand-over once."""

from __future__ import annotations

from mrss.messages import AllocationState, TaskAllocation, WaitReason
from mrss.messages.bid_reports import BidReport
from mrss.tui.models.alerts import AlertKind, AlertsModel
from mrss.tui.models.tasks import TasksModel

UNAVAILABLE = {"uav1": "link down: no heartbeat for 3.0 s"}


def award(robot: str, bids: list[BidReport], lost_from: str = "") -> TaskAllocation:
    return TaskAllocation(uuid="3f2a9c1b77", state=AllocationState.AWARDED, robot=robot,
                          name="cover", goal="a1", bids=[b.to_wire() for b in bids],
                          bidders=len(bids), evaluator="quickest_finish",
                          capabilities=["camera", "uav"], lost_from=lost_from)


def test_a_holder_is_explained_by_its_bid_and_the_runners_up() -> None:
    tasks = TasksModel()
    assert tasks.apply(award("uav3", [
        BidReport("uav3", finish_s=41.6, battery_after=71.0),
        BidReport("uav1", WaitReason.BUSY, busy_priority=5),
    ]), 10.0) is None
    view = tasks.tasks["3f2a9c1b77"]
    assert view.why() == "uav3: finish in 42 s, 71 % battery after; uav1 busy with priority 5"
    assert view.role == "any(camera, uav)" and tasks.held_by("uav3") == [view]


def test_a_fleet_names_the_best_four_and_counts_the_rest() -> None:
    tasks = TasksModel()
    bids = [BidReport(f"uav{i}", finish_s=float(i)) for i in range(1, 8)]
    message = award("uav1", bids)
    tasks.apply(TaskAllocation(**{**message.__dict__, "bidders": 40}), 1.0)
    assert tasks.tasks["3f2a9c1b77"].why().endswith("uav4: finish in 4 s; 36 more")


def test_a_waiting_task_says_what_it_waits_for_with_each_robots_reason() -> None:
    tasks = TasksModel()
    tasks.apply(TaskAllocation(
        uuid="t2", state=AllocationState.WAITING, wait=WaitReason.UNAVAILABLE,
        bids=[BidReport("uav1", WaitReason.UNAVAILABLE).to_wire(),
              BidReport("uav2", WaitReason.BATTERY, battery_after=8.0,
                        reserve=20.0).to_wire()],
        bidders=2, capabilities=["uav"], near=[-35.3632, 149.1652]), 1.0)
    view = tasks.tasks["t2"]
    assert view.role == "any(uav) near -35.3632, 149.1652"
    assert view.why(lambda r: UNAVAILABLE.get(r, "")) == (
        "no capable robot is available: uav1 unavailable: link down: no heartbeat for "
        "3.0 s; uav2 battery too low (8 % < reserve 20 %)")
    assert tasks.waiting() == [view] and not tasks.held_by("uav1")


def test_a_hand_over_is_one_reassignment_however_often_its_award_is_heard() -> None:
    tasks, alerts = TasksModel(), AlertsModel()
    tasks.apply(award("uav1", [BidReport("uav1", finish_s=3.0)]), 1.0)
    handed = award("uav2", [BidReport("uav2", finish_s=9.0),
                            BidReport("uav1", WaitReason.UNAVAILABLE)], lost_from="uav1")
    change = tasks.apply(handed, 2.0)
    assert change is not None and (change.lost_from, change.robot) == ("uav1", "uav2")
    assert change.subject == "cover a1 (3f2a9c1b)"
    assert tasks.apply(handed, 3.0) is None  # the same award again (a resend)
    view = tasks.tasks["3f2a9c1b77"]
    assert view.holders == ["uav1", "uav2"] and len(view.reassignments) == 1
    assert view.why().startswith("reassigned from uav1: uav2: finish in 9 s; uav1 unavailable")
    alert = alerts.reassigned(change.subject, "uav1", "uav2", 2.0, "link down")
    assert alert.kind is AlertKind.REASSIGNED
    assert alert.line() == "task reassigned: cover a1 (3f2a9c1b) from uav1 to uav2 (uav1: " \
        "link down)"
