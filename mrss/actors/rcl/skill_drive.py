"""One pass of a skill's state machine, START -> RUN -> FINISH, on its worker thread, and
its restarts under the skill's supervision policy (the restart rules are told in
mrss/actors/rcl/skill_actor.py's docstring, whose worker calls `drive`)."""

from __future__ import annotations

import logging
from typing import TYPE_CHECKING

from mrss.actors.rcl.failure_causes import failure_cause
from mrss.actors.rcl.skill import Skill, SkillInterrupted, SkillOutcome, SkillState
from mrss.supervision.events import ESCALATE, RESTART, SupEvents
from mrss.supervision.policy import Action as Choice
from mrss.supervision.policy import RestartPolicy
from mrss.supervision.reason import Cause, ExitReason
from mrss.supervision.spec import Backoff, ChildSpec, OnExceeded, SupervisorSpec

if TYPE_CHECKING:
    from mrss.actors.rcl.skill_actor import SkillRunner

log = logging.getLogger("mrss.rcl.skill")

#: A crash-looping skill waits 0.05 s before its second restart, doubling up to 2 s.
SKILL_BACKOFF = Backoff(initial=0.05, factor=2.0, cap=2.0, jitter=0.2)


def restart_policy(skill: Skill) -> RestartPolicy:
    """The policy deciding a skill's restarts: it alone, its `max_restarts` within its
    `restart_period`, escalation beyond (the action fails)."""
    spec = SupervisorSpec(intensity=max(0, int(skill.max_restarts)),
                          period=float(skill.restart_period), backoff=SKILL_BACKOFF,
                          on_exceeded=OnExceeded.ESCALATE)
    return RestartPolicy(spec, [ChildSpec(_child_id(skill), start=None)])


def _child_id(skill: Skill) -> str:
    return skill.name


def drive(skill: Skill, runner: SkillRunner) -> tuple[SkillOutcome, str, bool]:
    """Run the skill's state machine to FINISH on this thread; return outcome, reason and
    whether it escalated.

    A crash is decided by the skill's RestartPolicy (see the module docstring)."""
    policy, child = restart_policy(skill), _child_id(skill)
    events = SupEvents(f"robots/{runner.action.robot}", runner.publish, log)
    while True:
        policy.child_started(child)
        outcome, reason, crashed = _attempt(skill, runner)
        if crashed and not runner.interrupt_event.is_set():
            if skill.max_restarts <= 0:  # no budget: nothing to restart or escalate
                return (*_finish(skill, runner, outcome, reason), False)
            decision = policy.child_exited(child, ExitReason(Cause.CRASHED, reason))
            if decision.action is not Choice.RESTART:
                events.emit(ESCALATE, child, reason=reason, count=decision.count,
                            note=decision.note, action=runner.action.uuid,
                            index=runner.index)
                return (*_finish(skill, runner, outcome, reason), True)
            events.emit(RESTART, child, reason=reason, count=decision.count,
                        delay=round(decision.delay, 3), action=runner.action.uuid,
                        index=runner.index)
            _finish(skill, runner, SkillOutcome.FAILED, reason)
            runner.release_all()
            with runner.lock:
                skill._set_state(SkillState.START)
            if runner.interrupt_event.wait(decision.delay):
                with runner.lock:
                    if skill.state is SkillState.START:
                        skill._set_state(SkillState.INTERRUPT)
                    skill._set_state(SkillState.FINISH)
                return (*_finish(skill, runner, SkillOutcome.INTERRUPTED, ""), False)
            continue
        return (*_finish(skill, runner, outcome, reason), False)


def _attempt(skill: Skill, runner: SkillRunner) -> tuple[SkillOutcome, str, bool]:
    """One pass START -> RUN -> FINISH; (outcome, reason, crashed)."""
    outcome, reason, crashed = SkillOutcome.INTERRUPTED, "", False
    runner.cause = ""
    try:
        for resource in skill.resources:
            skill.acquire(resource)
        if not runner.interrupt_event.is_set():
            skill.start()
        with runner.lock:
            go = skill.state is SkillState.START
            if go:
                skill._set_state(SkillState.RUN)
        if go:
            outcome, reason = _normalise(skill, skill.run())
    except SkillInterrupted:
        outcome = SkillOutcome.INTERRUPTED
    except Exception as exc:
        outcome, crashed = SkillOutcome.FAILED, True
        reason = f"{skill.name} raised {type(exc).__name__}: {exc}"
        runner.cause = failure_cause(exc)
    with runner.lock:
        if skill.state is SkillState.INTERRUPT:
            outcome, reason, crashed = SkillOutcome.INTERRUPTED, "", False
        skill._set_state(SkillState.FINISH)
    return outcome, reason, crashed


def _normalise(skill: Skill, result: SkillOutcome | bool | None) -> tuple[SkillOutcome, str]:
    if isinstance(result, SkillOutcome):
        outcome = result
    else:
        outcome = SkillOutcome.FAILED if result is False else SkillOutcome.SUCCEEDED
    if outcome is SkillOutcome.SUCCEEDED:
        return outcome, ""
    return outcome, skill.reason or f"{skill.name} {outcome.value}"


def _finish(skill: Skill, runner: SkillRunner, outcome: SkillOutcome,
            reason: str) -> tuple[SkillOutcome, str]:
    """Call the skill's `finish` hook; a raising hook turns success into failure."""
    skill.outcome, skill.reason = outcome, reason
    try:
        skill.finish(outcome)
    except Exception as exc:
        log.error("skill %s: finish() raised %s: %s", skill.name, type(exc).__name__, exc)
        if outcome is SkillOutcome.SUCCEEDED:
            outcome = SkillOutcome.FAILED
            reason = f"{skill.name}.finish raised {type(exc).__name__}: {exc}"
            skill.outcome, skill.reason = outcome, reason
    return outcome, reason
