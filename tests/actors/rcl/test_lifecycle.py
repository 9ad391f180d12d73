"""The action lifecycle on its own: every phase x every event, each rule, the doc's table."""

from __future__ import annotations

import itertools
import re
from pathlib import Path

import pytest

from mrss.actors.rcl import lifecycle as lc
from mrss.actors.rcl.lifecycle import (
    ACTION_TRANSITIONS,
    RULES,
    EndCause,
    EventKind,
    Lifecycle,
    Phase,
    Stop,
    SuspendCause,
    step,
)
from mrss.errors import ActionError
from mrss.messages import ActionState, FailureCause

S = ActionState
DOC = Path(__file__).resolve().parents[3] / "docs" / "rcl.md"
ENDS = (S.SUCCEEDED, S.FAILED, S.CANCELLED)


def _records(phase: Phase) -> list[Lifecycle]:
    """Every distinct shape of a record in `phase`."""
    if phase is Phase.SUSPENDED:
        return [Lifecycle(phase, by) for by in SuspendCause]
    if phase is Phase.STOPPING:
        stops = [Stop(S.SUSPENDED, "why", by=by, resume_after=again)
                 for by in SuspendCause for again in (False, True)]
        stops += [Stop(target, "why", cause="") for target in ENDS]
        return [Lifecycle(phase, stop=stop) for stop in stops]
    return [Lifecycle(phase)]


def _events(kind: EventKind) -> list[lc.Event]:
    """Every distinct shape of an event of `kind`."""
    teleop = (False, True)
    return {
        EventKind.ACCEPT: [lc.Accept(t) for t in teleop],
        EventKind.RESTORE: [lc.Restore("an RCL restart", by, t)
                            for by in (None, *SuspendCause) for t in teleop],
        EventKind.REFINE_FAILED: [lc.RefineFailed("no recipe"),
                                  lc.RefineFailed("away", FailureCause.TRANSIENT)],
        EventKind.SKILL_ENDED: [lc.SkillEnded(a) for a in (False, True)],
        EventKind.VERDICT: [lc.Verdict(v, "r", FailureCause.TRANSIENT, a)
                            for v in (None, *ActionState) for a in (False, True)],
        EventKind.SUSPEND: [lc.Suspend(by) for by in SuspendCause],
        EventKind.RESUME: [lc.Resume(by, t) for by in SuspendCause for t in teleop],
        EventKind.END: [lc.End(target, by) for target in ENDS for by in EndCause],
        EventKind.STOPPED: [lc.Stopped()],
        EventKind.DEADLINE: [lc.DeadlinePassed()],
    }[kind]


def _public(phase: Phase) -> ActionState:
    """The ActionState the journal and the bus show in `phase`."""
    return S.RUNNING if phase is Phase.STOPPING else ActionState(phase.value)


@pytest.mark.parametrize(("phase", "kind"), list(itertools.product(Phase, EventKind)),
                         ids=lambda v: str(v))
def test_every_event_in_every_phase_follows_its_rule_or_is_an_error(
        phase: Phase, kind: EventKind) -> None:
    rule = RULES.get((phase, kind))
    for record, event in itertools.product(_records(phase), _events(kind)):
        if rule is None:
            with pytest.raises(lc.IllegalEvent) as info:
                step(record, event)
            assert f"event {kind.value!r} in phase {phase.value!r}" in info.value.reason
            continue
        after, effects = step(record, event)
        assert after.phase in rule.to, (record, event)
        state = _public(phase)
        for effect in effects:  # every published transition is legal, in order
            if isinstance(effect, lc.Publish):
                assert effect.state in ACTION_TRANSITIONS[state], (record, event, effects)
                state = effect.state
            elif isinstance(effect, lc.Run):
                state = S.RUNNING
        if after.phase is not Phase.STOPPING:
            published = any(isinstance(e, lc.Publish | lc.Run) for e in effects)
            assert published or after.phase is phase, (record, event, effects)
        assert (after.phase is Phase.STOPPING) == (after.stop is not None)
        assert (after.suspended_by is not None) == (after.phase is Phase.SUSPENDED)


def test_terminal_phases_have_no_rule() -> None:
    assert not [key for key in RULES if key[0].terminal]
    with pytest.raises(lc.IllegalEvent, match="allowed: none"):
        step(Lifecycle(Phase.CANCELLED), lc.Resume(SuspendCause.OPERATOR))


def test_accept_runs_or_suspends_under_teleop() -> None:
    assert step(Lifecycle(Phase.PENDING), lc.Accept()) == (Lifecycle(Phase.RUNNING),
                                                          (lc.Run(""),))
    after, effects = step(Lifecycle(Phase.PENDING), lc.Accept(teleop=True))
    assert after == Lifecycle(Phase.SUSPENDED, SuspendCause.TELEOP)
    assert effects == (lc.ReleaseResources(),
                       lc.Publish(S.SUSPENDED, "robot in teleop",
                                  suspended_by=SuspendCause.TELEOP))


@pytest.mark.parametrize(("by", "teleop", "kept"), [
    (SuspendCause.OPERATOR, False, True), (SuspendCause.AGENT, False, True),
    (SuspendCause.TELEOP, True, True), (SuspendCause.TELEOP, False, False),
    (SuspendCause.PREEMPTED, False, False),
])
def test_restore_keeps_goal_management_and_live_teleop_suspensions(
        by: SuspendCause, teleop: bool, kept: bool) -> None:
    after, effects = step(Lifecycle(Phase.SUSPENDED, by),
                          lc.Restore("an RCL restart", by, teleop))
    if kept:
        assert after.phase is Phase.SUSPENDED and after.suspended_by is by
        assert effects == (lc.Announce(f"still suspended ({by.value}) after an RCL restart",
                                       by),)
    else:
        assert effects == (lc.Run("resumed after an RCL restart"),)


def test_suspend_interrupts_then_suspends_and_only_preemption_keeps_resources() -> None:
    for by in SuspendCause:
        stopping, effects = step(Lifecycle(Phase.RUNNING), lc.Suspend(by, "why"))
        assert stopping.phase is Phase.STOPPING
        assert effects == (lc.Interrupt(urgent=by is SuspendCause.TELEOP),)
        after, effects = step(stopping, lc.Stopped())
        assert after == Lifecycle(Phase.SUSPENDED, by)
        released = lc.ReleaseResources() in effects
        assert released == (by is not SuspendCause.PREEMPTED)
        assert effects[-1] == lc.Publish(S.SUSPENDED, "why", suspended_by=by)


def test_a_stronger_cause_takes_over_and_a_weaker_does_not() -> None:
    preempted = Lifecycle(Phase.SUSPENDED, SuspendCause.PREEMPTED)
    after, effects = step(preempted, lc.Suspend(SuspendCause.TELEOP, "robot in teleop"))
    assert after.suspended_by is SuspendCause.TELEOP
    assert effects == (lc.ReleaseResources(),  # no longer waits for the resource
                       lc.Announce("robot in teleop", SuspendCause.TELEOP))
    assert step(after, lc.Suspend(SuspendCause.PREEMPTED)) == (after, ())
    after, _ = step(after, lc.Suspend(SuspendCause.OPERATOR))
    assert after.suspended_by is SuspendCause.OPERATOR


def test_a_resume_lifts_only_its_cause_except_goal_management_short_of_teleop() -> None:
    teleop = Lifecycle(Phase.SUSPENDED, SuspendCause.TELEOP)
    assert step(teleop, lc.Resume(SuspendCause.PREEMPTED)) == (teleop, ())
    assert step(teleop, lc.Resume(SuspendCause.OPERATOR, teleop=True)) == (teleop, ())
    operator = Lifecycle(Phase.SUSPENDED, SuspendCause.OPERATOR)
    assert step(operator, lc.Resume(SuspendCause.TELEOP)) == (operator, ())
    after, effects = step(operator, lc.Resume(SuspendCause.OPERATOR, teleop=True))
    assert after.suspended_by is SuspendCause.TELEOP and effects == ()  # waits for teleop
    after, effects = step(Lifecycle(Phase.SUSPENDED, SuspendCause.PREEMPTED),
                          lc.Resume(SuspendCause.AGENT))
    assert after.phase is Phase.RUNNING and effects == (lc.Run("resumed by the agent"),)


def test_a_resume_during_a_stop_runs_again_and_a_later_suspend_cancels_it() -> None:
    stopping, _ = step(Lifecycle(Phase.RUNNING), lc.Suspend(SuspendCause.PREEMPTED))
    again, effects = step(stopping, lc.Resume(SuspendCause.PREEMPTED))
    assert effects == () and again.stop is not None and again.stop.resume_after
    assert step(again, lc.Stopped()) == (Lifecycle(Phase.RUNNING), (lc.Run(""),))
    held, _ = step(again, lc.Suspend(SuspendCause.OPERATOR))
    assert held.stop is not None and not held.stop.resume_after
    assert held.stop.by is SuspendCause.OPERATOR
    after, _ = step(held, lc.Stopped())
    assert after == Lifecycle(Phase.SUSPENDED, SuspendCause.OPERATOR)


def test_an_end_wins_over_a_suspension_in_progress_and_ends_a_suspended_action_at_once(
        ) -> None:
    stopping, _ = step(Lifecycle(Phase.RUNNING), lc.Suspend(SuspendCause.TELEOP))
    ending, effects = step(stopping, lc.End(S.CANCELLED, EndCause.OPERATOR))
    assert effects == () and ending.stop == Stop(S.CANCELLED, "cancelled by the operator",
                                                 FailureCause.CANCELLED, urgent=True)
    assert step(ending, lc.Suspend(SuspendCause.OPERATOR)) == (ending, ())
    after, effects = step(ending, lc.DeadlinePassed())
    assert after.phase is Phase.CANCELLED
    assert effects == (lc.Abandon(), lc.Publish(S.CANCELLED, "cancelled by the operator",
                                                FailureCause.CANCELLED))
    after, effects = step(Lifecycle(Phase.SUSPENDED, SuspendCause.PREEMPTED),
                          lc.End(S.FAILED, EndCause.LINK_LOST, "robot ugv1 unreachable"))
    assert after.phase is Phase.FAILED
    assert effects == (lc.Publish(S.FAILED, "robot ugv1 unreachable", FailureCause.LINK_DOWN),)


@pytest.mark.parametrize(("target", "by", "cause"), [
    (S.CANCELLED, EndCause.OPERATOR, FailureCause.CANCELLED),
    (S.CANCELLED, EndCause.AGENT, FailureCause.CANCELLED),
    (S.CANCELLED, EndCause.ORPHANED, FailureCause.ORPHANED),
    (S.FAILED, EndCause.OPERATOR, ""),
    (S.FAILED, EndCause.LINK_LOST, FailureCause.LINK_DOWN),
    (S.FAILED, EndCause.FAILSAFE, FailureCause.FAILSAFE),
    (S.FAILED, EndCause.QUARANTINED, FailureCause.QUARANTINED),
    (S.FAILED, EndCause.REJECTED, FailureCause.REJECTED),
    (S.SUCCEEDED, EndCause.OPERATOR, ""),
])
def test_each_end_cause_reaches_the_agent_as_its_failure_cause(
        target: ActionState, by: EndCause, cause: str) -> None:
    assert lc.End(target, by).failure() == cause
    assert set(lc.FAILURE_OF) == set(EndCause)


def test_verdicts_end_a_running_action() -> None:
    running = Lifecycle(Phase.RUNNING)
    assert step(running, lc.Verdict(None)) == (running, ())
    after, _ = step(running, lc.Verdict(None, all_ended=True))
    assert after.stop == Stop(S.FAILED, "every skill ended without a verdict")
    after, _ = step(running, lc.Verdict(S.SUSPENDED, all_ended=True))
    assert after.stop is not None and after.stop.target is S.FAILED
    after, _ = step(running, lc.Verdict(S.SUCCEEDED, "", FailureCause.TRANSIENT))
    assert after.stop == Stop(S.SUCCEEDED, "")  # no failure cause on a success


def test_an_unrouted_end_is_checked_against_the_table() -> None:
    publish = lc.end_unrouted(S.SUSPENDED, lc.End(S.FAILED, EndCause.QUARANTINED, "q"))
    assert publish == lc.Publish(S.FAILED, "q", FailureCause.QUARANTINED)
    with pytest.raises(ActionError, match="illegal transition failed -> failed"):
        lc.end_unrouted(S.FAILED, lc.End(S.FAILED, EndCause.QUARANTINED))


def test_suspend_causes_read_from_older_journals() -> None:
    assert SuspendCause.parse("") is None
    assert SuspendCause.parse("control") is SuspendCause.OPERATOR
    assert SuspendCause.parse("resource:airspace") is SuspendCause.PREEMPTED
    assert SuspendCause.parse("teleop") is SuspendCause.TELEOP


def test_docs_rcl_md_carries_the_lifecycle_table_generated_from_the_module() -> None:
    text = DOC.read_text(encoding="utf-8")
    found = re.search(r"<!-- lifecycle-table -->\n(.*?)<!-- /lifecycle-table -->", text,
                      re.S)
    assert found, "docs/rcl.md lacks the <!-- lifecycle-table --> block"
    assert found.group(1) == lc.table_markdown(), (
        "docs/rcl.md's lifecycle table is out of date; paste lifecycle.table_markdown()")


# -- critical sections: which stops wait for one (Skill.critical) -------------------------
@pytest.mark.parametrize("by", list(SuspendCause))
def test_only_a_teleop_suspension_interrupts_inside_a_critical_section(
        by: SuspendCause) -> None:
    stopping, effects = step(Lifecycle(Phase.RUNNING), lc.Suspend(by))
    assert stopping.stop is not None and stopping.stop.urgent is (by is SuspendCause.TELEOP)
    assert effects == (lc.Interrupt(urgent=by is SuspendCause.TELEOP),)


@pytest.mark.parametrize("by", list(lc.EndCause))
def test_ends_the_robot_cannot_wait_for_interrupt_inside_a_critical_section(
        by: lc.EndCause) -> None:
    waits = by in {lc.EndCause.OPERATOR, lc.EndCause.AGENT, lc.EndCause.ORPHANED,
                   lc.EndCause.REJECTED, lc.EndCause.PREEMPTED,
                   lc.EndCause.BATTERY_CRITICAL}  # a robot low on battery still hears us
    assert (by in lc.WAITS_FOR_CRITICAL) is waits
    _, effects = step(Lifecycle(Phase.RUNNING), lc.End(S.CANCELLED, by))
    assert effects == (lc.Interrupt(urgent=not waits),)


def test_a_teleop_makes_a_deferred_preemption_urgent_and_takes_it_over() -> None:
    deferred, _ = step(Lifecycle(Phase.RUNNING), lc.Suspend(SuspendCause.PREEMPTED))
    after, effects = step(deferred, lc.Suspend(SuspendCause.TELEOP, "robot in teleop"))
    assert effects == (lc.Interrupt(urgent=True),)
    assert after.stop is not None and after.stop.urgent and after.stop.by is SuspendCause.TELEOP
    again, effects = step(after, lc.Suspend(SuspendCause.TELEOP))  # urgent already
    assert effects == () and again == after


def test_a_link_loss_makes_a_deferred_cancel_urgent_and_keeps_the_cancel() -> None:
    deferred, _ = step(Lifecycle(Phase.RUNNING), lc.End(S.CANCELLED, lc.EndCause.OPERATOR))
    after, effects = step(deferred, lc.End(S.FAILED, lc.EndCause.LINK_LOST))
    assert effects == (lc.Interrupt(urgent=True),)
    assert after.stop is not None and after.stop.target is S.CANCELLED and after.stop.urgent


def test_a_cancel_replacing_a_deferred_suspension_still_waits_for_the_section() -> None:
    deferred, _ = step(Lifecycle(Phase.RUNNING), lc.Suspend(SuspendCause.OPERATOR))
    after, effects = step(deferred, lc.End(S.CANCELLED, lc.EndCause.OPERATOR))
    assert effects == ()
    assert after.stop is not None and after.stop.target is S.CANCELLED
    assert not after.stop.urgent


def test_a_verdict_waits_for_a_critical_section() -> None:
    _, effects = step(Lifecycle(Phase.RUNNING), lc.Verdict(S.SUCCEEDED))
    assert effects == (lc.Interrupt(urgent=False),)
