"""The checker's rules, each on hand-made histories: one that holds, ones that break it."""

from __future__ import annotations

from mrss.chaos.checker import Bounds, GoalOutcome, Invariant, Judgement, Verdict, check
from mrss.chaos.history import parse
from mrss.chaos.views import STATUS_TRAVEL
from tests.chaos.histories import (
    TREE,
    U1,
    U2,
    Record,
    action,
    bus,
    edit,
    healthy,
    log,
    operator,
    probe,
    request,
    robot_state,
    status,
    transitions,
)


def verdict(records: list[Record]) -> Verdict:
    return check(parse(records), Bounds(latch=15.0, cancel=15.0, converge=60.0))


def broken(records: list[Record]) -> set[Invariant]:
    return {v.invariant for v in verdict(records).violations}


def with_second_action(records: list[Record], state: str, created: float,
                       ended: float | None = None, inc: int = 1) -> list[Record]:
    """Add U2, cover(uav1,a2), to the journal (terminal at `ended` if given)."""
    journal = edit(records, "journal")
    journal["actions"].append(action(U2, "a2", state, created, inc=inc))
    steps = [("pending", created), ("running", created + 0.1)]
    if ended is not None:
        steps.append((state, ended))
    journal["transitions"] += transitions(U2, *steps, first_seq=10)
    records.append(request(created - 0.1, U2, "a2", inc=inc))
    return records


def test_the_healthy_history_holds_every_invariant() -> None:
    v = verdict(healthy())
    assert v.violations == []
    assert v.goals == {"a1": GoalOutcome.SUCCEEDED}
    assert v.acted_on == {"a1"}
    assert v.converged_after == 25.0


# -- exactly one terminal state -----------------------------------------------------------
def test_two_terminal_transitions_in_the_journal_break_one_terminal_state() -> None:
    records = healthy()
    edit(records, "journal")["transitions"] += transitions(U1, ("failed", 11.0), first_seq=4)
    found = verdict(records).of(Invariant.ONE_TERMINAL)
    assert [v.subject for v in found] == [U1]
    assert "failed" in found[0].evidence[1]


def test_two_different_terminal_statuses_on_the_bus_break_one_terminal_state() -> None:
    records = healthy() + [status(11.0, U1, "failed")]
    assert Invariant.ONE_TERMINAL in broken(records)


def test_a_repeated_terminal_status_is_not_a_second_one() -> None:
    records = healthy() + [status(11.0, U1, "succeeded")]
    assert broken(records) == set()


def test_a_request_never_journaled_breaks_one_terminal_state() -> None:
    records = healthy() + [request(12.0, U2, "a1")]
    found = verdict(records).of(Invariant.ONE_TERMINAL)
    assert [v.subject for v in found] == [U2]
    assert found[0].evidence[1] == "never in the RCL journal"


def test_a_request_of_an_incarnation_that_died_right_after_may_be_lost() -> None:
    records = healthy() + [request(12.0, U2, "a1"),
                           bus(13.0, "sup.heartbeat", {"component": "reasoner", "pid": 101},
                               src="reasoner", inc=2)]
    assert Invariant.ONE_TERMINAL not in broken(records)


def compacted_away(records: list[Record], dropped: int = 1, before: float = 20.0
                   ) -> list[Record]:
    """The journal without U1, as its compaction leaves it: `dropped` actions gone, none
    ended before `before` left."""
    journal = edit(records, "journal")
    journal["actions"] = [a for a in journal["actions"] if a["uuid"] != U1]
    journal["transitions"] = [x for x in journal["transitions"] if x["uuid"] != U1]
    journal.update(compacted=dropped, compacted_before=before)
    return records


def test_an_action_compacted_away_is_judged_by_its_terminal_status_on_the_bus() -> None:
    v = verdict(compacted_away(healthy()))
    assert v.violations == []
    assert v.goals == {"a1": GoalOutcome.SUCCEEDED}  # its success, as the bus showed it
    # U1 judged, by the bus's time, as the sweep is by the journal's
    assert v.rulings[Invariant.LATCH_RELEASED].checked == 2


def test_an_action_missing_without_compaction_is_still_never_journaled() -> None:
    records = compacted_away(healthy(), dropped=0)
    found = verdict(records).of(Invariant.ONE_TERMINAL)
    assert [v.subject for v in found] == [U1]
    assert found[0].evidence[1] == "never in the RCL journal"
    assert Invariant.GOAL_HANDLED in broken(records)  # its success is not taken on trust


def test_an_action_that_ended_after_the_compaction_watermark_was_never_journaled() -> None:
    records = compacted_away(healthy(), before=10.0 - STATUS_TRAVEL - 0.5)
    found = verdict(records).of(Invariant.ONE_TERMINAL)
    assert [v.subject for v in found] == [U1]
    assert "not compacted either: the journal's compaction dropped 1" in found[0].evidence[2]


def test_compaction_excuses_no_more_actions_than_it_dropped() -> None:
    records = compacted_away(healthy()) + [request(12.0, U2, "a1"),
                                           status(12.5, U2, "succeeded")]
    found = verdict(records).of(Invariant.ONE_TERMINAL)
    assert [v.subject for v in found] == [U2]  # the later-ended one: compaction drops
    records = compacted_away(healthy(), dropped=2) + [request(12.0, U2, "a1"),  # oldest
                                                      status(12.5, U2, "succeeded")]
    assert broken(records) == {Invariant.LATCH_RELEASED}  # judged too, by the bus
    found = verdict(records).of(Invariant.LATCH_RELEASED)
    assert found[0].evidence[1] == "bus (compacted away) succeeded at 12.5s"
    records.append(log(12.6, "reasoner", f"action {U2} cover(uav1,a1) succeeded"))
    assert verdict(records).violations == []


def test_a_request_never_shown_terminal_is_not_excused_by_compaction() -> None:
    records = compacted_away(healthy()) + [request(12.0, U2, "a1")]
    found = verdict(records).of(Invariant.ONE_TERMINAL)
    assert [v.subject for v in found] == [U2]


# -- no transition after a terminal one -----------------------------------------------------
def test_a_journal_transition_after_the_terminal_one_is_caught() -> None:
    records = healthy()
    edit(records, "journal")["transitions"] += transitions(U1, ("running", 11.0), first_seq=4)
    found = verdict(records).of(Invariant.NO_TRANSITION_AFTER_TERMINAL)
    assert [v.subject for v in found] == [U1]
    assert "running" in found[0].evidence[-1]


def test_a_status_published_after_the_terminal_one_is_caught() -> None:
    records = healthy() + [status(11.0, U1, "running")]
    assert broken(records) == {Invariant.NO_TRANSITION_AFTER_TERMINAL}


def test_progress_repeats_while_running_break_nothing_but_one_after_the_end_is_caught() -> None:
    progress = [status(t, U1, "running") for t in (3.0, 4.0, 5.0)]
    for record, leg in zip(progress, (1, 2, 3), strict=True):
        record["body"].update(progress={"leg": leg, "of": 4}, repeat=True)
    records = healthy()
    end = next(i for i, r in enumerate(records) if r.get("kind") == "action.status"
               and r["body"]["state"] == "succeeded")
    assert broken(records[:end] + progress + records[end:]) == set()
    late = status(11.0, U1, "running")  # the RCL must never let one out after the end
    late["body"].update(progress={"leg": 4, "of": 4}, repeat=True)
    assert broken(healthy() + [late]) == {Invariant.NO_TRANSITION_AFTER_TERMINAL}


def test_a_late_status_of_an_older_rcl_incarnation_is_ignored() -> None:
    records = healthy()
    for r in records:
        if r["type"] == "bus" and r["kind"] == "action.status":
            r["inc"] = 2
    records.append(status(11.0, U1, "running", inc=1))
    assert broken(records) == set()


# -- latches released ------------------------------------------------------------------------
def test_no_release_of_the_latch_breaks_latch_released() -> None:
    records = [r for r in healthy() if r["type"] != "logline"]
    found = verdict(records).of(Invariant.LATCH_RELEASED)
    assert [v.subject for v in found] == [U1]
    assert "requester still alive" in found[0].evidence[-1]


def test_a_release_later_than_the_bound_breaks_latch_released() -> None:
    records = [r for r in healthy() if r["type"] != "logline"]
    records.append(log(30.0, "reasoner", f"action {U1} cover(uav1,a1) succeeded"))
    assert broken(records) == {Invariant.LATCH_RELEASED}


def test_a_release_seen_on_the_bus_log_counts() -> None:
    records = [r for r in healthy() if r["type"] != "logline"]
    records.append(bus(10.2, "log.record", {"component": "reasoner", "level": "INFO",
                                            "message": f"action {U1} cover(uav1,a1) "
                                                       "succeeded"}, src="reasoner"))
    assert broken(records) == set()


def test_a_latch_of_a_dead_reasoner_incarnation_is_released_by_its_death() -> None:
    records = [r for r in healthy() if r["type"] != "logline"]
    records.append(bus(12.0, "sup.event", {"event": "exit", "child": "reasoner",
                                           "detail": {"inc": 1}}, src="supervisor", inc=0))
    assert Invariant.LATCH_RELEASED not in broken(records)


# -- operator goals ----------------------------------------------------------------------------
def test_an_accepted_goal_nobody_acted_on_is_dropped() -> None:
    records = healthy() + [operator(20.0, "goal", "a2")]
    v = verdict(records)
    assert v.goals["a2"] is GoalOutcome.DROPPED
    assert [x.subject for x in v.of(Invariant.GOAL_HANDLED)] == ["a2"]


def test_a_goal_reported_failed_to_the_operator_is_handled() -> None:
    records = healthy() + [operator(20.0, "goal", "a2"),
                           {"type": "reply", "t": 25.0, "topic": "mrss/ui/reply/area",
                            "payload": '{"goal": "a2", "error": "world model down"}'}]
    v = verdict(records)
    assert v.goals["a2"] is GoalOutcome.REPORTED and v.violations == []


def test_a_goal_the_agent_still_holds_at_the_end_is_handled() -> None:
    records = healthy() + [operator(20.0, "goal", "a2")]
    records.append(probe(35.0, beliefs=["queued(uav1,a2,3,cover)[source(self)]"]))
    assert verdict(records).goals["a2"] is GoalOutcome.HELD


def test_a_belief_outside_the_pending_ones_does_not_hold_a_goal() -> None:
    records = healthy() + [operator(20.0, "goal", "a2")]
    records.append(probe(35.0, beliefs=["failed_goal(a2)[source(self)]"]))
    assert verdict(records).goals["a2"] is GoalOutcome.DROPPED


def test_a_goal_the_agent_says_failed_where_the_operator_sees_it_is_reported() -> None:
    """The project's `[operator.goals] failed` belief is how its dashboard tells the
    operator a goal failed: a failed goal the final mind says so of is not dropped."""
    records = with_second_action(healthy() + [operator(19.0, "goal", "a2")], "failed",
                                 20.0, ended=21.0)
    records.append(log(21.05, "reasoner", f"action {U2} cover(uav1,a2) failed"))
    records[0]["failed_beliefs"] = ["failed_goal"]
    assert verdict(records).goals["a2"] is GoalOutcome.DROPPED  # the mind says nothing
    records.append(probe(35.0, beliefs=["failed_goal(a3)[source(self)]",
                                        "done_goal(a2)[source(self)]"]))
    assert verdict(records).goals["a2"] is GoalOutcome.DROPPED  # another goal's, not a2's
    records.append(probe(36.0, beliefs=["failed_goal(a2)[source(self)]"]))
    v = verdict(records)
    assert v.goals["a2"] is GoalOutcome.REPORTED and v.violations == []


def test_a_goal_whose_action_failed_silently_is_dropped() -> None:
    records = with_second_action(healthy() + [operator(19.0, "goal", "a2")], "failed",
                                 20.0, ended=21.0)
    records.append(log(21.05, "reasoner", f"action {U2} cover(uav1,a2) failed"))
    v = verdict(records)
    assert v.goals["a2"] is GoalOutcome.DROPPED and "a2" in v.acted_on
    assert "cover failed" in v.of(Invariant.GOAL_HANDLED)[0].evidence[1]


def test_a_goal_the_broker_did_not_accept_is_not_counted() -> None:
    records = healthy() + [operator(20.0, "goal", "a2", ok=False)]
    assert "a2" not in verdict(records).goals


# -- no robot command for a cancelled or orphaned action -----------------------------------------
def test_skills_started_for_a_terminal_action_are_caught() -> None:
    records = healthy() + [log(11.0, "rcl", f"action {U1} is already cancelled; running "
                                            "dropped")]
    found = verdict(records).of(Invariant.NO_COMMAND_AFTER_CANCEL)
    assert [v.subject for v in found] == [U1]


def test_an_action_still_running_long_after_the_reasoner_cancelled_it_is_caught() -> None:
    records = with_second_action(healthy(), "running", 11.0)
    records.append(bus(12.0, "action.control", {"command": "cancel", "target": U2,
                                                "target_kind": "action"}, src="reasoner"))
    records.append(probe(35.0, waiting=[U2], open_actions=[
        {"uuid": U2, "state": "running", "robot": "uav1", "goal": "a2",
         "requester": "reasoner", "requester_inc": 1}]))
    found = verdict(records).of(Invariant.NO_COMMAND_AFTER_CANCEL)
    assert [v.subject for v in found] == [U2]
    assert "still running at the end" in found[0].evidence[1]


def test_an_action_cancelled_in_time_is_fine() -> None:
    records = with_second_action(healthy(), "cancelled", 11.0, ended=13.0)
    records.append(bus(12.0, "action.control", {"command": "cancel", "target": U2,
                                                "target_kind": "action"}, src="reasoner"))
    records.append(log(13.1, "reasoner", f"action {U2} cover(uav1,a2) cancelled"))
    assert Invariant.NO_COMMAND_AFTER_CANCEL not in broken(records)


def test_an_action_of_a_goal_the_operator_cancelled_must_stop() -> None:
    records = healthy()
    records.append(operator(5.0, "cancel", "a1"))
    edit(records, "journal")["transitions"][-1]["t"] = 25.0
    found = verdict(records).of(Invariant.NO_COMMAND_AFTER_CANCEL)
    assert [v.subject for v in found] == [U1]
    assert "succeeded only at 25.0s" in found[0].evidence[1]


def test_an_action_requested_for_a_cancelled_goal_is_caught() -> None:
    records = healthy() + [operator(0.5, "goal", "a2"), operator(5.0, "cancel", "a2")]
    records = with_second_action(records, "cancelled", 11.0, ended=12.0)
    records.append(log(12.1, "reasoner", f"action {U2} cover(uav1,a2) cancelled"))
    found = verdict(records).of(Invariant.NO_COMMAND_AFTER_CANCEL)
    assert [v.subject for v in found] == [U2]
    assert "requested for it at 11.0s" in found[0].evidence[1]


def test_an_orphan_of_a_dead_reasoner_that_keeps_running_is_caught() -> None:
    records = with_second_action(healthy(), "running", 11.0)
    records.append(bus(12.0, "sup.heartbeat", {"component": "reasoner", "pid": 101},
                       src="reasoner", inc=2))
    found = verdict(records).of(Invariant.NO_COMMAND_AFTER_CANCEL)
    assert [v.subject for v in found] == [U2]
    assert "not adopted" in found[0].evidence[1]


def test_an_orphan_adopted_by_the_new_incarnation_is_fine() -> None:
    records = with_second_action(healthy(), "running", 11.0)
    records.append(bus(12.0, "sup.heartbeat", {"component": "reasoner", "pid": 101},
                       src="reasoner", inc=2))
    records.append(request(13.0, "c" * 32, "a2", inc=2))
    assert Invariant.NO_COMMAND_AFTER_CANCEL not in broken(records)


# -- modes -----------------------------------------------------------------------------------------
def test_a_robot_left_in_teleop_after_the_operator_switched_it_off_is_caught() -> None:
    records = healthy() + [bus(6.0, "robot.data", {"robot": "ugv1", "data": {"teleop": True}})]
    found = verdict(records).of(Invariant.MODE_CONSISTENT)
    assert [v.subject for v in found] == ["ugv1 teleop"]
    assert found[0].evidence[1] == "robot sees it on"


def test_a_reasoner_that_still_believes_in_teleop_is_caught() -> None:
    records = healthy() + [probe(35.0, beliefs=["paused(ugv1,teleop)[source(self)]"])]
    assert broken(records) == {Invariant.MODE_CONSISTENT}


def test_an_rcl_journal_with_teleop_on_is_caught() -> None:
    records = healthy()
    edit(records, "journal")["teleop"] = {"ugv1": True}
    assert "rcl sees it on" in verdict(records).of(Invariant.MODE_CONSISTENT)[0].evidence


def test_teleop_left_on_by_the_operator_is_consistent_when_everyone_sees_it_on() -> None:
    records = healthy() + [operator(4.2, "mode", robot="ugv1", mode="teleop", on=True),
                           bus(4.6, "robot.data", {"robot": "ugv1", "data": {"teleop": True}}),
                           probe(35.0, beliefs=["paused(ugv1,teleop)[source(self)]"])]
    edit(records, "journal")["teleop"] = {"ugv1": True}
    assert broken(records) == set()


def test_an_rcl_never_switched_for_the_robot_is_no_view_of_its_mode() -> None:
    """Chaos seed 7: the wildfire agent switches teleop with a skill, never with the RCL's
    own flag (ctl.teleop), so the journal has no flag for the robot; the operator's last
    switch was on and the robot and the reasoner saw it on."""
    records = healthy() + [operator(4.2, "mode", robot="ugv1", mode="teleop", on=True),
                           bus(4.6, "robot.data", {"robot": "ugv1", "data": {"teleop": True}}),
                           probe(35.0, beliefs=["paused(ugv1,teleop)[source(self)]"])]
    assert edit(records, "journal")["teleop"] == {}
    assert broken(records) == set()
    edit(records, "journal")["teleop"] = {"ugv1": False}  # switched, and off: it counts
    assert "rcl sees it off" in verdict(records).of(Invariant.MODE_CONSISTENT)[0].evidence


# -- convergence -----------------------------------------------------------------------------------
def test_an_intention_waiting_on_a_finished_action_is_not_converged() -> None:
    records = [r for r in healthy() if r["type"] != "probe"] + [probe(30.0, waiting=[U1])]
    v = verdict(records)
    assert v.converged_after is None
    found = v.of(Invariant.CONVERGED)
    assert any(f"waits on action {U1}" in e for e in found[0].evidence)


def test_an_open_action_nobody_waits_on_is_not_converged() -> None:
    orphan = {"uuid": U2, "state": "running", "robot": "uav1", "goal": "a2",
              "requester": "reasoner", "requester_inc": 1}
    records = [r for r in healthy() if r["type"] != "probe"] + [probe(30.0, open_actions=[
        orphan])]
    assert any("no intention waits on it" in e
               for e in verdict(records).of(Invariant.CONVERGED)[0].evidence)


def test_a_component_down_is_not_converged_and_a_later_probe_may_be() -> None:
    down = {**TREE, "children": [{"id": "rcl", "state": "waiting", "children": []}]}
    records = [r for r in healthy() if r["type"] != "probe"]
    records += [probe(20.0, tree=down), probe(30.0)]
    v = verdict(records)
    assert v.violations == [] and v.converged_after == 25.0


def test_converging_later_than_the_bound_is_a_violation() -> None:
    records = healthy()
    edit(records, "probe")["t"] = 90.0
    found = verdict(records).of(Invariant.CONVERGED)
    assert "converged only 85.0s later" in found[0].evidence


def test_no_probe_after_the_faults_leaves_convergence_undetermined() -> None:
    """A campaign always probes after the faults: a history without such a probe was cut
    short, and says nothing about convergence either way."""
    records = [r for r in healthy() if r["type"] != "probe"]
    edit(records, "end")["exit_code"] = 1
    v = verdict(records)
    assert v.of(Invariant.CONVERGED) == []
    assert v.judgement(Invariant.CONVERGED) is Judgement.INCOMPLETE
    assert "mrss supervise exited 1" in v.why(Invariant.CONVERGED)


def test_a_probe_that_finds_the_system_stopped_is_not_converged() -> None:
    records = [r for r in healthy() if r["type"] != "probe"]
    records.append({"type": "probe", "t": 30.0, "mind": None, "tree": None,
                    "open_actions": None, "system_running": False})
    found = verdict(records).of(Invariant.CONVERGED)
    assert "mrss supervise is not running" in found[0].evidence


# -- no robot stuck -----------------------------------------------------------------------
def test_an_action_running_without_news_past_its_skills_bound_is_a_stuck_robot() -> None:
    records = [r for r in healthy()  # no news of U1 after it started running at 2.2 s
               if not (r["type"] == "bus" and r["t"] in (2.3, 6.0, 7.0))]
    found = verdict(records).of(Invariant.NO_ROBOT_STUCK)  # 2.2 s -> 10.0 s: 7.8 s > 6 s
    assert [v.subject for v in found] == [U1]
    assert found[0].evidence[0] == "robot uav1, action cover (progress bound 6s)"
    assert "from 2.2s for 7.8s: next succeeded at 10.0s" in found[0].evidence[1]


def test_an_action_still_running_at_the_end_past_its_bound_is_stuck() -> None:
    records = healthy()
    records = [r for r in records if not (r["type"] == "bus" and r["t"] == 10.0)]
    journal = edit(records, "journal")
    journal["actions"] = [action(U1, "a1", "running", 2.1)]
    journal["transitions"] = transitions(U1, ("pending", 2.1), ("running", 2.2))
    found = verdict(records).of(Invariant.NO_ROBOT_STUCK)
    assert [v.subject for v in found] == [U1]
    assert "still running at the end (40.0s)" in found[0].evidence[1]


def test_without_a_declared_bound_no_robot_stuck_has_nothing_to_check() -> None:
    records = healthy()
    for r in records:
        if r["type"] == "bus" and r["kind"] == "action.status":
            r["body"].pop("progress_bound", None)  # as a recording older than the field
    v = verdict(records)
    assert v.judgement(Invariant.NO_ROBOT_STUCK) is Judgement.VACUOUS


def test_the_bound_is_read_from_the_status_field_not_from_the_log() -> None:
    records = [r for r in healthy()  # no news of U1 after it started running at 2.2 s
               if not (r["type"] == "bus" and r["t"] in (2.3, 6.0, 7.0))]
    records.append(log(2.2, "rcl", f"skill CoverArea of action {U1} runs with a progress "
                                   "bound of 60s"))  # the old log line says nothing now
    found = verdict(records).of(Invariant.NO_ROBOT_STUCK)
    assert [v.subject for v in found] == [U1]
    assert "(progress bound 6s)" in found[0].evidence[0]


# -- heals to the same state --------------------------------------------------------------
def test_a_robot_available_before_the_faults_and_not_after_breaks_healed() -> None:
    records = healthy()
    records.append(robot_state(20.0, "uav1", available=False, link="down"))
    found = verdict(records).of(Invariant.HEALED)
    assert [v.subject for v in found] == ["system"]
    assert found[0].evidence == ("robot uav1: available, link up before the first fault "
                                 "(5.0s); at the end unavailable, link down",)


def test_a_robot_down_before_the_faults_need_not_come_up_for_healed() -> None:
    records = healthy()
    records.insert(3, robot_state(0.8, "ugv1", available=False, link="down"))
    assert verdict(records).judgement(Invariant.HEALED) is Judgement.HOLDS


def test_an_orphan_action_at_the_last_probe_breaks_healed() -> None:
    records = healthy()
    orphan = {"uuid": U2, "state": "running", "robot": "uav1", "goal": "a2",
              "requester": "reasoner", "requester_inc": 1}
    records.insert(records.index(edit(records, "journal")), probe(35.0, open_actions=[orphan]))
    found = verdict(records).of(Invariant.HEALED)
    assert [v.subject for v in found] == ["system"]
    assert "is open but no intention waits on it" in found[0].evidence[0]
    # it converged at 30 s all the same: healed judges the end, not the first calm probe
    assert verdict(records).judgement(Invariant.CONVERGED) is Judgement.HOLDS


# -- critical sections ----------------------------------------------------------------------
def _cancelled_inside_a_section(closed: float) -> list[Record]:
    """U2 is in a critical section (bound 30 s) from 11.5 s to `closed` and is cancelled by
    the reasoner at 12 s; it ends 1 s after the section."""
    records = with_second_action(healthy(), "cancelled", 11.0, ended=closed + 1.0)
    records += [status(11.5, U2, "running", critical="landing", bound=30.0),
                bus(12.0, "action.control", {"command": "cancel", "target": U2,
                                             "target_kind": "action"}, src="reasoner"),
                status(12.1, U2, "running", critical="landing", bound=30.0, deferring=True),
                status(closed, U2, "running", reason="critical section 'landing' ended"),
                status(closed + 1.0, U2, "cancelled"),
                log(closed + 1.1, "reasoner", f"action {U2} cover(uav1,a2) cancelled")]
    edit(records, "journal")["t"] = 80.0
    return records


def test_a_cancel_deferred_by_a_critical_section_counts_from_its_end() -> None:
    records = _cancelled_inside_a_section(closed=38.0)  # 26 s after the cancel, > 15 s
    assert not {Invariant.NO_COMMAND_AFTER_CANCEL, Invariant.CRITICAL_BOUNDED} & broken(
        records)


def test_a_section_held_past_its_bound_is_caught_and_does_not_excuse_a_late_cancel() -> None:
    records = _cancelled_inside_a_section(closed=60.0)  # held 48.5 s, bound 30 s
    found = verdict(records)
    bounded = found.of(Invariant.CRITICAL_BOUNDED)
    assert [v.subject for v in bounded] == [U2]
    assert "held 48.5s" in bounded[0].evidence[2]
    late = found.of(Invariant.NO_COMMAND_AFTER_CANCEL)  # from the bound, 41.5 s: 61 > 56.5
    assert [v.subject for v in late] == [U2]


def test_a_section_still_open_at_the_end_counts_until_then() -> None:
    records = healthy()
    records.insert(6, status(2.4, U2, "running", critical="arm", bound=1.0))
    found = verdict(records).of(Invariant.CRITICAL_BOUNDED)
    assert [v.subject for v in found] == [U2] and "still open at the end" in found[0].evidence[1]
