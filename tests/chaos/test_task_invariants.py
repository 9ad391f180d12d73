"""The task invariants over hand-made histories: never two holders, awarded within the
bound; each must be able to fail, and says "vacuous" when it had nothing to judge.

The base history is `healthy()` (its sweep, a task addressed to a role, is awarded to
uav1 at once). `lost_and_reassigned` adds a second UAV and a sweep t2 that uav1 runs
until a `robot_loss` takes uav1 away at 20 s; the RCL gives t2 back (PENDING on no robot,
"reassigning") and awards it to uav2 ("reassigned from uav1 (lost)"), which finishes it.
The award bound of these histories is 8 s (3 s link loss, 2 s allocation, 3 s margin).
"""

from __future__ import annotations

import json
from pathlib import Path

import pytest

from mrss.chaos.campaign import parse_kinds, plan
from mrss.chaos.checker import Bounds, Invariant, Judgement, Verdict, check
from mrss.chaos.faults import ALL_KINDS, FaultKind, targets
from mrss.chaos.history import parse
from mrss.chaos.task_bound import AwardBound, award_bound, robot_capabilities
from mrss.cli import main
from mrss.config.loader import load_project
from tests.chaos.histories import (
    Record,
    allocation,
    bus,
    edit,
    healthy,
    robot_state,
    role_request,
    status,
)

T2 = "f" * 32
FLEET = Path(__file__).resolve().parent / "projects"


def verdict(records: list[Record], **bounds: float) -> Verdict:
    return check(parse(records), Bounds(latch=15.0, cancel=15.0, converge=60.0, **bounds))


def on(robot: str, record: Record) -> Record:
    record["body"]["robot"] = robot
    return record


def rcl_exit(t: float) -> Record:
    """The root supervisor saw the RCL's first incarnation exit (it is restarted)."""
    return bus(t, "sup.event", {"event": "exit", "child": "rcl", "detail": {"inc": 1}},
               src="supervisor", inc=0)


def timed(records: list[Record]) -> list[Record]:
    """In time order (the bus records as the recorder heard them), the campaign first."""
    return sorted(records, key=lambda r: (r["type"] != "campaign", r.get("t", 0.0)))


def lost_and_reassigned(award_at: float = 23.5, *more: Record) -> list[Record]:
    records = healthy()
    edit(records, "campaign")["robots"]["uav2"] = ["uav", "camera"]
    records += [
        robot_state(0.7, "uav2"),
        role_request(13.0, T2, "t2"),
        allocation(13.05, T2, "awarded", "uav1", "uav1: finish in 9 s"),
        status(13.1, T2, "running"),
        {"type": "fault", "t": 20.0, "kind": "robot_loss", "target": "uav1", "pid": 0,
         "duration": 0.0, "ok": True, "holding": [T2]},
        robot_state(23.0, "uav1", available=False, link="down"),
        on("", status(23.0, T2, "pending", reason="reassigning: robot uav1 unreachable")),
        allocation(award_at, T2, "awarded", "uav2",
                   "reassigned from uav1 (lost): uav2: finish in 5 s"),
        on("uav2", status(award_at + 0.1, T2, "running")),
        on("uav2", status(award_at + 5.0, T2, "succeeded")),
        *more,
    ]
    return timed(records)


# -- never two holders ----------------------------------------------------------------------------
def test_a_task_reassigned_after_its_robot_was_lost_has_one_holder_at_a_time() -> None:
    v = verdict(lost_and_reassigned())
    assert v.judgement(Invariant.NEVER_TWO_HOLDERS) is Judgement.HOLDS
    assert v.rulings[Invariant.NEVER_TWO_HOLDERS].checked == 2  # the sweeps t1 and t2
    assert v.judgement(Invariant.AWARD_BOUNDED) is Judgement.HOLDS
    assert v.judgement(Invariant.HEALED) is Judgement.HOLDS  # uav1 is gone for good


def test_an_award_to_a_second_robot_while_the_first_holds_the_task_is_two_holders() -> None:
    records = [r for r in lost_and_reassigned()
               if not (r["type"] == "bus" and r["kind"] == "action.status"
                       and r["body"]["uuid"] == T2 and r["body"]["state"] == "pending")]
    for r in records:  # an award that does not say uav1 lost it
        if r["type"] == "bus" and r["kind"] == "action.allocation" \
                and r["body"]["robot"] == "uav2":
            r["body"]["why"] = "uav2: finish in 5 s"
    found = verdict(records).of(Invariant.NEVER_TWO_HOLDERS)
    assert [v.subject for v in found] == [T2]
    assert found[0].evidence[0] == "task sweep(any([uav]),t2) (uav)"
    assert "awarded to uav2 at 23.5s while uav1 held it (since 13.1s)" in found[0].evidence
    assert verdict(records).judgement(Invariant.NEVER_TWO_HOLDERS) is Judgement.FAILS


def test_the_lost_robot_still_running_its_task_after_the_reaward_is_two_holders() -> None:
    records = lost_and_reassigned(23.5, status(25.0, T2, "running"))  # on uav1
    found = verdict(records).of(Invariant.NEVER_TWO_HOLDERS)
    assert [v.subject for v in found] == [T2]
    assert "running on uav1 at 25.0s while uav2 held it (since 23.5s)" in found[0].evidence


def test_an_award_decided_again_for_the_robot_holding_the_task_is_caught() -> None:
    again = allocation(15.0, T2, "awarded", "uav1", "uav1: finish in 7 s")
    found = verdict(lost_and_reassigned(23.5, again)).of(Invariant.NEVER_TWO_HOLDERS)
    assert [v.subject for v in found] == [T2]
    assert "awarded to uav1 again at 15.0s while it held it (since 13.1s)" in \
        found[0].evidence


def test_a_release_lost_on_the_bus_is_found_in_the_journal() -> None:
    records = [r for r in lost_and_reassigned()
               if not (r["type"] == "bus" and r["kind"] == "action.status"
                       and r["body"]["uuid"] == T2 and r["body"]["state"] == "pending")]
    for r in records:
        if r["type"] == "bus" and r["kind"] == "action.allocation" \
                and r["body"]["robot"] == "uav2":
            r["body"]["why"] = "uav2: finish in 5 s"
    edit(records, "journal")["transitions"].append(
        {"seq": 30, "uuid": T2, "state": "pending", "t": 23.0,
         "reason": "reassigning: robot uav1 unreachable"})
    assert verdict(records).of(Invariant.NEVER_TWO_HOLDERS) == []


def test_a_dead_rcl_incarnations_late_status_is_no_holder() -> None:
    late = status(25.0, T2, "running", inc=1)  # uav1's, from the RCL's dead incarnation
    restarted = bus(24.0, "sup.heartbeat", {"component": "rcl", "pid": 9}, inc=2)
    assert verdict(lost_and_reassigned(23.5, late)).of(Invariant.NEVER_TWO_HOLDERS) != []
    assert verdict(lost_and_reassigned(23.5, restarted, late)).of(
        Invariant.NEVER_TWO_HOLDERS) == []


# -- awarded within the bound ---------------------------------------------------------------------
def test_a_late_award_while_a_capable_robot_was_free_breaks_award_bounded() -> None:
    v = verdict(lost_and_reassigned(award_at=40.0))
    found = v.of(Invariant.AWARD_BOUNDED)
    assert [x.subject for x in found] == [T2]
    assert found[0].evidence == (
        "task sweep(any([uav]),t2) (uav)", "waiting from 20.0s",  # the loss, not the release
        "uav2 could take it from 20.0s to 40.0s (capable, available, link up, holding no "
        "action)", "awarded to uav2 at 40.0s", "bound 8.0s")
    assert v.judgement(Invariant.AWARD_BOUNDED) is Judgement.FAILS
    assert v.judgement(Invariant.NEVER_TWO_HOLDERS) is Judgement.HOLDS


def test_the_bound_counts_from_the_loss_so_the_link_timeout_is_in_it() -> None:
    assert verdict(lost_and_reassigned(award_at=27.9)).of(Invariant.AWARD_BOUNDED) == []
    assert verdict(lost_and_reassigned(award_at=28.1)).of(Invariant.AWARD_BOUNDED) != []
    # --award-bound replaces the derived bound
    assert verdict(lost_and_reassigned(award_at=28.1), award=10.0).of(
        Invariant.AWARD_BOUNDED) == []


def test_a_task_never_awarded_while_a_robot_was_free_breaks_award_bounded() -> None:
    records = [r for r in lost_and_reassigned(award_at=1000.0) if r.get("t", 0) < 30.0
               or r["type"] in ("journal", "log", "end", "probe")]
    found = verdict(records).of(Invariant.AWARD_BOUNDED)
    assert [x.subject for x in found] == [T2]
    assert found[0].evidence[3] == "still waiting at the end at 40.0s"


def test_a_wait_while_every_capable_robot_is_busy_or_unable_is_no_violation() -> None:
    busy = lost_and_reassigned(  # uav2 runs something else meanwhile
        40.0, on("uav2", status(19.0, "9" * 32, "running")),
        on("uav2", status(39.9, "9" * 32, "succeeded")))
    assert verdict(busy).of(Invariant.AWARD_BOUNDED) == []
    unable = lost_and_reassigned(award_at=40.0)
    edit(unable, "campaign")["robots"]["uav2"] = ["ugv"]  # no uav capability
    assert verdict(unable).of(Invariant.AWARD_BOUNDED) == []
    out = lost_and_reassigned(40.0, robot_state(19.0, "uav2", available=False))
    assert verdict(out).of(Invariant.AWARD_BOUNDED) == []
    battery = lost_and_reassigned(40.0, allocation(23.2, T2, "waiting", wait="battery",
                                                   why="uav2 would come home at 12 %"))
    assert verdict(battery).of(Invariant.AWARD_BOUNDED) == []


def test_a_restart_or_a_stall_of_the_rcl_in_the_wait_stretches_the_bound() -> None:
    restarted = lost_and_reassigned(40.0, rcl_exit(30.0))
    assert verdict(restarted).of(Invariant.AWARD_BOUNDED) == []  # 8 + 15 s
    before = lost_and_reassigned(40.0, rcl_exit(16.0))  # just before the wait: it counts
    assert verdict(lost_and_reassigned(40.0, rcl_exit(4.0))).of(Invariant.AWARD_BOUNDED)
    assert verdict(before).of(Invariant.AWARD_BOUNDED) == []
    bus_killed = lost_and_reassigned(40.0, {"type": "fault", "t": 24.0, "kind": "kill",
                                            "target": "bus", "pid": 5, "duration": 0.0,
                                            "ok": True})
    assert verdict(bus_killed).of(Invariant.AWARD_BOUNDED) == []
    hung = lost_and_reassigned(35.0, {"type": "fault", "t": 24.0, "kind": "hang",
                                      "target": "rcl", "pid": 5, "duration": 10.0,
                                      "ok": True})
    assert verdict(hung).of(Invariant.AWARD_BOUNDED) == []  # 8 + 10 s


def test_no_task_leaves_both_vacuous_never_holding() -> None:
    records = [r for r in healthy() if not (r["type"] == "bus" and r["body"].get("uuid")
                                            == "e" * 32)]
    v = verdict(records)
    for invariant in (Invariant.NEVER_TWO_HOLDERS, Invariant.AWARD_BOUNDED):
        assert v.judgement(invariant) is Judgement.VACUOUS
    assert v.why(Invariant.NEVER_TWO_HOLDERS) == "no task addressed to a role was awarded"


def test_a_history_of_tasks_without_robots_or_bound_cannot_judge_the_award() -> None:
    records = healthy()
    del edit(records, "campaign")["robots"]
    v = verdict(records)
    assert v.judgement(Invariant.AWARD_BOUNDED) is Judgement.INCOMPLETE
    assert v.judgement(Invariant.NEVER_TWO_HOLDERS) is Judgement.HOLDS


# -- the bound, the fault kind ------------------------------------------------------------------
def test_the_award_bound_is_derived_from_the_project() -> None:
    config = load_project("fleetloss", FLEET)
    bound = award_bound(config)
    # heartbeat_timeout 3 s; the allocator's 1 s retry (no wait per robot: an award
    # asks no robot to confirm); the root's backoff cap 5 s + the RCL's start_timeout 10 s
    assert bound == AwardBound(3.0, 1.0, 15.0, 3.0, ("bus", "rcl"))
    assert bound.base == 7.0 and AwardBound.of_record(bound.record()) == bound
    assert robot_capabilities(config) == {"uav1": ["camera", "uav"], "uav2": ["camera", "uav"]}


def test_robot_loss_is_drawn_only_when_named_and_takes_each_robot_once() -> None:
    assert FaultKind.ROBOT_LOSS not in parse_kinds("all")
    assert set(ALL_KINDS) == set(FaultKind) - {FaultKind.ROBOT_LOSS}
    found = targets(load_project("fleetloss", FLEET))
    assert found[FaultKind.ROBOT_LOSS] == ["uav1", "uav2"]
    faults = plan(4, 5, [FaultKind.ROBOT_LOSS, FaultKind.KILL], found, (1.0, 2.0),
                  (1.0, 2.0))
    lost = [f.target for f in faults if f.kind is FaultKind.ROBOT_LOSS]
    assert len(lost) == len(set(lost)) and lost
    assert all(f.duration == 0.0 for f in faults if f.kind is FaultKind.ROBOT_LOSS)


def test_mrss_chaos_award_bound_replaces_the_derived_one_and_must_not_be_negative(
        tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    path = tmp_path / "h.jsonl"
    path.write_text("\n".join(json.dumps(r) for r in lost_and_reassigned(30.0)) + "\n")
    assert main(["chaos", "--check", str(path), "--json"]) == 1  # 10 s > the derived 8 s
    assert json.loads(capsys.readouterr().out)["invariants"]["award-bounded"][
        "judgement"] == "fails"
    main(["chaos", "--check", str(path), "--json", "--award-bound", "12"])
    assert json.loads(capsys.readouterr().out)["invariants"]["award-bounded"][
        "judgement"] == "holds"
    assert main(["chaos", "wildfire", "--award-bound", "-1"]) == 2
    assert "--award-bound: must be >= 0" in capsys.readouterr().err
