"""The action lifecycle: every transition of an action, its cause and its effects, as data.

Pure: no threads, no I/O. The robot actor feeds `step` the events it sees (a request
accepted, a skill ended, a control, a teleop, a stop completed) and carries out the
effects it gets back, in order (start or interrupt skills, journal and publish a status,
release resources). The RCL core ends actions whose robot actor is gone the same way
(`end_unrouted`). A reader answers "when does an action become suspended, and who
resumes it?" from `RULES` below, which docs/rcl.md prints as a table.

Phases are the public `ActionState`s plus STOPPING: the action's skills were interrupted
and it waits for them to end (at most the layer's `interrupt_timeout`) before it moves to
`Stop.target`. Rules, each one function below:
- accepted: RUNNING (skills started), or SUSPENDED at once while the robot is in teleop;
- restored after an RCL or robot-actor restart: a suspension by goal management, or by a
  teleop still in force, is kept (re-announced); anything else runs again from progress;
- a suspension has a cause (`SuspendCause`), strongest first: goal management (operator
  or agent), teleop, pre-emption. A stronger cause takes over a weaker one; a resume lifts
  only its own cause, except a goal-management resume, which lifts any cause but a teleop
  still in force (then the action waits for the teleop to end);
- a pre-empted action keeps its place with the resource broker (it is a candidate when
  the resource frees); any other suspension releases its resources;
- an end (cancel, succeed, fail, by whoever: `EndCause`) interrupts the skills, then
  moves to the terminal state; an end wins over a suspension in progress; a suspended
  action ends at once;
- the project's verdict (`check_action_status`) ends a RUNNING action; every skill ended
  without a verdict fails it;
- a skill inside a critical section (`Skill.critical`) is interrupted when the section
  ends: a suspension (by goal management or a pre-emption), an end by goal management,
  an orphaning or a rejection, and a verdict wait for it (their `Interrupt` is not
  urgent). A teleop (the operator's emergency stop: hands on the robot) and the ends
  the robot cannot wait for (link lost, failsafe, node down, quarantine, RCL restart)
  interrupt inside the section; one arriving during a deferred stop makes it urgent;
- a terminal state is final: every event for it is an error.
"""

from __future__ import annotations

import dataclasses
from collections.abc import Callable, Mapping
from dataclasses import dataclass

from mrss.actors.rcl.lifecycle_words import (
    ACTION_TRANSITIONS,
    FAILURE_OF,
    WAITS_FOR_CRITICAL,
    Abandon,
    Accept,
    Announce,
    CheckStatus,
    DeadlinePassed,
    Effect,
    End,
    EndCause,
    Event,
    EventKind,
    IllegalEvent,
    Interrupt,
    Lifecycle,
    Phase,
    Publish,
    RefineFailed,
    ReleaseResources,
    Restore,
    Resume,
    Run,
    SkillEnded,
    Step,
    Stop,
    Stopped,
    Suspend,
    SuspendCause,
    Verdict,
    check_action_transition,
)
from mrss.messages import ActionState

__all__ = [
    "ACTION_TRANSITIONS",
    "Abandon",
    "Accept",
    "Announce",
    "CheckStatus",
    "DeadlinePassed",
    "Effect",
    "End",
    "EndCause",
    "Event",
    "EventKind",
    "FAILURE_OF",
    "IllegalEvent",
    "Interrupt",
    "Lifecycle",
    "Phase",
    "Publish",
    "RefineFailed",
    "ReleaseResources",
    "Restore",
    "Resume",
    "Run",
    "SkillEnded",
    "Step",
    "Stop",
    "Stopped",
    "Suspend",
    "SuspendCause",
    "Verdict",
    "WAITS_FOR_CRITICAL",
    "check_action_transition",
]


# -- the rules: one function each ---------------------------------------------------------
def _accept(lc: Lifecycle, ev: Accept) -> Step:
    if ev.teleop:
        return _suspended(SuspendCause.TELEOP, "robot in teleop")
    if ev.held is not None:
        return _suspended(ev.held, ev.why or f"its goal is suspended by the {ev.held.value}")
    return Lifecycle(Phase.RUNNING), (Run(""),)


def _restore(lc: Lifecycle, ev: Restore) -> Step:
    by = lc.suspended_by
    if lc.phase is Phase.SUSPENDED and by is not None and (
            by.goal_management or (ev.teleop and by is SuspendCause.TELEOP)):
        return lc, (Announce(f"still suspended ({by.value}) after {ev.why}", by),)
    if lc.phase is not Phase.SUSPENDED and ev.teleop:
        return _suspended(SuspendCause.TELEOP, "robot in teleop")
    return Lifecycle(Phase.RUNNING), (Run(f"resumed after {ev.why}"),)


def _refine_failed(lc: Lifecycle, ev: RefineFailed) -> Step:
    return _finish(ActionState.FAILED, ev.reason, ev.cause)


def _skill_ended_running(lc: Lifecycle, ev: SkillEnded) -> Step:
    return lc, (CheckStatus(),)


def _skill_ended_stopping(lc: Lifecycle, ev: SkillEnded) -> Step:
    return _complete_stop(lc) if ev.all_ended else (lc, ())


def _verdict(lc: Lifecycle, ev: Verdict) -> Step:
    state, reason = ev.state, ev.reason
    if state is None and not ev.all_ended:
        return lc, ()
    if state is None:
        state, reason = ActionState.FAILED, "every skill ended without a verdict"
    elif not state.terminal:
        state, reason = ActionState.FAILED, f"check_action_status returned {state!r}"
    cause = ev.cause if state is ActionState.FAILED else ""
    return _stopping(Stop(state, reason, cause))


def _suspend_running(lc: Lifecycle, ev: Suspend) -> Step:
    return _stopping(Stop(ActionState.SUSPENDED, ev.reason or ev.by.imposed,
                          by=ev.by, urgent=not ev.by.waits_for_critical))


def _suspend_stopping(lc: Lifecycle, ev: Suspend) -> Step:
    stop = lc.stop
    assert stop is not None
    if stop.target is not ActionState.SUSPENDED:
        return _hurry(lc, stop, not ev.by.waits_for_critical)  # ending anyway
    stronger = stop.by is None or ev.by.rank > stop.by.rank
    new = dataclasses.replace(stop, resume_after=False, by=ev.by if stronger else stop.by,
                              reason=(ev.reason or ev.by.imposed) if stronger
                              else stop.reason)
    return _hurry(lc, new, not ev.by.waits_for_critical)


def _suspend_suspended(lc: Lifecycle, ev: Suspend) -> Step:
    if lc.suspended_by is not None and ev.by.rank <= lc.suspended_by.rank:
        return lc, ()
    reason = ev.reason or ev.by.imposed
    # no longer waiting for a resource: give up the claim a pre-emption kept
    keep = (ReleaseResources(),) if lc.suspended_by is SuspendCause.PREEMPTED else ()
    return dataclasses.replace(lc, suspended_by=ev.by), (*keep, Announce(reason, ev.by))


def _resume_suspended(lc: Lifecycle, ev: Resume) -> Step:
    if not ev.by.goal_management and ev.by is not lc.suspended_by:
        return lc, ()  # suspended for another reason, which still holds
    if ev.teleop:
        return dataclasses.replace(lc, suspended_by=SuspendCause.TELEOP), ()  # waits for it
    return Lifecycle(Phase.RUNNING), (Run(ev.by.lifted),)


def _resume_stopping(lc: Lifecycle, ev: Resume) -> Step:
    stop = lc.stop
    assert stop is not None
    if (stop.target is ActionState.SUSPENDED and not ev.teleop
            and (ev.by.goal_management or ev.by is stop.by)):
        return dataclasses.replace(lc, stop=dataclasses.replace(stop, resume_after=True)), ()
    return lc, ()


def _ignore(lc: Lifecycle, ev: Event) -> Step:
    return lc, ()


def _end_running(lc: Lifecycle, ev: End) -> Step:
    return _stopping(Stop(ev.target, _end_reason(ev), ev.failure(), urgent=ev.urgent))


def _end_stopping(lc: Lifecycle, ev: End) -> Step:
    stop = lc.stop
    assert stop is not None
    if stop.target is not ActionState.SUSPENDED:
        return _hurry(lc, stop, ev.urgent)  # already ending
    return _hurry(lc, Stop(ev.target, _end_reason(ev), ev.failure(), urgent=stop.urgent),
                  ev.urgent)


def _end_at_once(lc: Lifecycle, ev: End) -> Step:
    return _finish(ev.target, _end_reason(ev), ev.failure())


def _stopped(lc: Lifecycle, ev: Stopped) -> Step:
    return _complete_stop(lc)


def _deadline(lc: Lifecycle, ev: DeadlinePassed) -> Step:
    after, effects = _complete_stop(lc)
    return after, (Abandon(), *effects)


# -- shared pieces of the rules -----------------------------------------------------------
def _end_reason(ev: End) -> str:
    verb = {ActionState.CANCELLED: "cancelled", ActionState.SUCCEEDED: "succeeded",
            ActionState.FAILED: "failed"}[ev.target]
    return ev.reason or f"{verb} by the {ev.by.value}"


def _stopping(stop: Stop) -> Step:
    return Lifecycle(Phase.STOPPING, stop=stop), (Interrupt(stop.urgent),)


def _hurry(lc: Lifecycle, stop: Stop, urgent: bool) -> Step:
    """The stop in progress becomes `stop`; an urgent event makes a stop that waited for
    a critical section urgent (the skills are interrupted again, inside it)."""
    if urgent and not stop.urgent:
        return (dataclasses.replace(lc, stop=dataclasses.replace(stop, urgent=True)),
                (Interrupt(urgent=True),))
    return dataclasses.replace(lc, stop=stop), ()


def _finish(state: ActionState, reason: str, cause: str) -> Step:
    return Lifecycle(Phase.of(state)), (Publish(state, reason, cause),)


def _suspended(by: SuspendCause, reason: str) -> Step:
    keep = (ReleaseResources(),) if by is not SuspendCause.PREEMPTED else ()
    return (Lifecycle(Phase.SUSPENDED, suspended_by=by),
            (*keep, Publish(ActionState.SUSPENDED, reason, suspended_by=by)))


def _complete_stop(lc: Lifecycle) -> Step:
    stop = lc.stop
    assert stop is not None
    if stop.target is not ActionState.SUSPENDED:
        return _finish(stop.target, stop.reason, stop.cause)
    if stop.resume_after:
        return Lifecycle(Phase.RUNNING), (Run(""),)
    return _suspended(stop.by or SuspendCause.OPERATOR, stop.reason)


# -- the table ----------------------------------------------------------------------------
@dataclass(frozen=True)
class Rule:
    """What an event does in a phase: the phases it may lead to, in words, and how."""

    to: frozenset[Phase]
    effect: str
    apply: Callable[[Lifecycle, Event], Step]


def _rule(to: set[Phase], effect: str, apply: Callable[..., Step]) -> Rule:
    return Rule(frozenset(to), effect, apply)


_PE, _RU, _ST, _SU = Phase.PENDING, Phase.RUNNING, Phase.STOPPING, Phase.SUSPENDED
_ENDS = {Phase.SUCCEEDED, Phase.FAILED, Phase.CANCELLED}
K = EventKind

#: Every (phase, event) with a rule; any other pair raises IllegalEvent.
RULES: Mapping[tuple[Phase, EventKind], Rule] = {
    (_PE, K.ACCEPT): _rule({_RU, _SU}, "start skills; SUSPENDED if in teleop or its goal "
                           "is held (held_goals.py)",
                           _accept),
    (_PE, K.RESTORE): _rule({_RU, _SU}, "run from progress; SUSPENDED if in teleop",
                            _restore),
    (_RU, K.RESTORE): _rule({_RU, _SU}, "run from progress; SUSPENDED if in teleop",
                            _restore),
    (_SU, K.RESTORE): _rule({_RU, _SU}, "kept (re-announced) if suspended by goal "
                            "management or a teleop still on; else run from progress",
                            _restore),
    (_RU, K.REFINE_FAILED): _rule({Phase.FAILED}, "publish FAILED", _refine_failed),
    (_RU, K.SKILL_ENDED): _rule({_RU}, "ask check_action_status", _skill_ended_running),
    (_ST, K.SKILL_ENDED): _rule({_ST, _SU, _RU} | _ENDS, "complete the stop when the "
                                "last skill ended", _skill_ended_stopping),
    (_RU, K.VERDICT): _rule({_RU, _ST}, "a terminal verdict (or none with every skill "
                            "ended: FAILED) interrupts the rest", _verdict),
    (_RU, K.SUSPEND): _rule({_ST}, "interrupt skills (after a critical section, but for a "
                            "teleop), then SUSPENDED", _suspend_running),
    (_ST, K.SUSPEND): _rule({_ST}, "a stronger cause takes over a stop toward SUSPENDED; "
                            "cancels a pending resume; a teleop interrupts inside a "
                            "critical section", _suspend_stopping),
    (_SU, K.SUSPEND): _rule({_SU}, "a stronger cause takes over (re-announced; a "
                            "pre-emption's claim on its resource is given up)",
                            _suspend_suspended),
    (_RU, K.RESUME): _rule({_RU}, "nothing", _ignore),
    (_ST, K.RESUME): _rule({_ST}, "run again once stopped, if it lifts the stop's cause "
                           "and no teleop holds", _resume_stopping),
    (_SU, K.RESUME): _rule({_SU, _RU}, "run from progress if it lifts the cause and no "
                           "teleop holds", _resume_suspended),
    (_RU, K.END): _rule({_ST}, "interrupt skills (after a critical section, unless the "
                        "robot is lost), then the end", _end_running),
    (_ST, K.END): _rule({_ST}, "an end replaces a stop toward SUSPENDED; one the robot "
                        "cannot wait for interrupts inside a critical section",
                        _end_stopping),
    (_SU, K.END): _rule(_ENDS, "publish the end at once", _end_at_once),
    (_ST, K.STOPPED): _rule({_SU, _RU} | _ENDS, "complete the stop", _stopped),
    (_ST, K.DEADLINE): _rule({_SU, _RU} | _ENDS, "abandon the skills, complete the stop",
                             _deadline),
    (_RU, K.DEADLINE): _rule({_RU}, "nothing (a stale timer)", _ignore),
    (_SU, K.DEADLINE): _rule({_SU}, "nothing (a stale timer)", _ignore),
}


def step(lc: Lifecycle, event: Event) -> Step:
    """The action's next place and the effects to carry out, in order; IllegalEvent if
    the table has no rule for this event in this phase."""
    rule = RULES.get((lc.phase, event.kind))
    if rule is None:
        allowed = sorted(k.value for (p, k) in RULES if p is lc.phase)
        raise IllegalEvent(f"no lifecycle rule for event {event.kind.value!r} in phase "
                           f"{lc.phase.value!r} (allowed: {', '.join(allowed) or 'none'})")
    after, effects = rule.apply(lc, event)
    if after.phase not in rule.to:  # the table's promise, kept by every rule
        raise AssertionError(f"{event!r} in {lc.phase.value} led to {after.phase.value}")
    return after, effects


def end_unrouted(state: ActionState, ev: End) -> Publish:
    """The end of an action no robot actor runs (its robot is gone or quarantined, a new
    run or an RCL restart that cannot resume it): publish it at once."""
    check_action_transition(state, ev.target)
    return Publish(ev.target, _end_reason(ev), ev.failure())


def table_markdown() -> str:
    """The lifecycle as a Markdown table (docs/rcl.md carries it verbatim)."""
    lines = ["| phase | event | next phase | effect |", "|---|---|---|---|"]
    for (phase, kind), rule in RULES.items():
        to = ", ".join(p.value.upper() for p in Phase if p in rule.to)
        lines.append(f"| {phase.value.upper()} | {kind.value} | {to} | {rule.effect} |")
    return "\n".join(lines) + "\n"
