"""The words of the action lifecycle: phases, causes, the events it reads, the effects it
returns, and an action's record; with the table of legal public transitions.

What the rules do with them is `mrss.actors.rcl.lifecycle`.
"""


from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass
from enum import StrEnum

from mrss.errors import ActionError
from mrss.messages import ActionState, FailureCause

_P, _R, _S = ActionState.PENDING, ActionState.RUNNING, ActionState.SUSPENDED
_OK, _KO, _CA = ActionState.SUCCEEDED, ActionState.FAILED, ActionState.CANCELLED

#: The one table of legal (public) action transitions; terminal states lead nowhere.
ACTION_TRANSITIONS: Mapping[ActionState, frozenset[ActionState]] = {
    _P: frozenset({_R, _S, _OK, _KO, _CA}),  # SUSPENDED: arrived while its robot is in teleop
    _R: frozenset({_S, _OK, _KO, _CA}),
    _S: frozenset({_R, _OK, _KO, _CA}),      # RUNNING again: resumed, refined from progress
    _OK: frozenset(), _KO: frozenset(), _CA: frozenset(),
}


def check_action_transition(old: ActionState, new: ActionState, uuid: str = "") -> None:
    """Raise ActionError unless `old -> new` is in ACTION_TRANSITIONS."""
    if new not in ACTION_TRANSITIONS[old]:
        raise ActionError(f"illegal transition {old.value} -> {new.value}", uuid=uuid or None)


class Phase(StrEnum):
    """Where an action is in its lifecycle: an ActionState, or stopping its skills."""

    PENDING = "pending"
    RUNNING = "running"
    STOPPING = "stopping"  # skills interrupted; moves to Stop.target once they have ended
    SUSPENDED = "suspended"
    SUCCEEDED = "succeeded"
    FAILED = "failed"
    CANCELLED = "cancelled"

    @property
    def terminal(self) -> bool:
        return self in (Phase.SUCCEEDED, Phase.FAILED, Phase.CANCELLED)

    @classmethod
    def of(cls, state: ActionState) -> Phase:
        return cls(state.value)


class SuspendCause(StrEnum):
    """Why an action is suspended (journaled, so a restart knows who may resume it)."""

    OPERATOR = "operator"  # goal management from the operator (dashboard, `mrss send`)
    AGENT = "agent"  # goal management from the agent that requested the action
    TELEOP = "teleop"  # its robot is teleoperated
    PREEMPTED = "preempted"  # a higher-priority action took a resource it holds

    @property
    def rank(self) -> int:
        """Strength: a stronger cause takes over a weaker one."""
        return {SuspendCause.TELEOP: 2, SuspendCause.PREEMPTED: 1}.get(self, 3)

    @property
    def goal_management(self) -> bool:
        return self in (SuspendCause.OPERATOR, SuspendCause.AGENT)

    @property
    def waits_for_critical(self) -> bool:
        """Whether a suspension for this cause waits for a skill's critical section to
        end (`Skill.critical`); a teleop, the operator's hands on the robot, does not."""
        return self is not SuspendCause.TELEOP

    @property
    def lifted(self) -> str:
        """The reason of the RUNNING status when this cause is lifted."""
        return {SuspendCause.OPERATOR: "resumed by the operator",
                SuspendCause.AGENT: "resumed by the agent",
                SuspendCause.TELEOP: "resumed: teleop ended",
                SuspendCause.PREEMPTED: "resumed: its resource is free"}[self]

    @property
    def imposed(self) -> str:
        """The default reason of the SUSPENDED status for this cause."""
        return {SuspendCause.OPERATOR: "suspended by the operator",
                SuspendCause.AGENT: "suspended by the agent",
                SuspendCause.TELEOP: "robot in teleop",
                SuspendCause.PREEMPTED: "pre-empted"}[self]

    @classmethod
    def parse(cls, text: str) -> SuspendCause | None:
        """From the journal: "" is None; values of older versions are read too."""
        if not text:
            return None
        legacy = {"control": cls.OPERATOR}
        if text in legacy:
            return legacy[text]
        if text.startswith("resource:"):
            return cls.PREEMPTED
        return cls(text)


class EndCause(StrEnum):
    """Who or what ended an action by command (the cause of its terminal transition)."""

    OPERATOR = "operator"  # goal management from the operator
    AGENT = "agent"  # goal management from the requesting agent
    LINK_LOST = "link_lost"  # the robot's link went down
    FAILSAFE = "failsafe"  # the robot lost its controller and took its safe state
    ORPHANED = "orphaned"  # its requester's incarnation died and nobody adopted it
    QUARANTINED = "quarantined"  # the robot's actor kept crashing
    RCL_RESTARTED = "rcl_restarted"  # an RCL restart could not resume it
    REJECTED = "rejected"  # the request was malformed or refused
    PREEMPTED = "preempted"  # pre-empted for longer than the RCL's preempted_timeout
    NODE_DOWN = "node_down"  # the node the robot is reached through was lost
    DECOMMISSIONED = "decommissioned"  # the operator took the robot out of service
    BATTERY_CRITICAL = "battery_critical"  # its battery fell below its critical level


#: The end causes that wait for a skill's critical section to end (`Skill.critical`);
#: the others (the robot lost, in its failsafe, behind a lost node, quarantined, an RCL
#: restart) interrupt inside the section: there is nothing to wait for. A robot whose
#: battery is critical still hears us: its section (a landing) ends first.
WAITS_FOR_CRITICAL: frozenset[EndCause] = frozenset({
    EndCause.OPERATOR, EndCause.AGENT, EndCause.ORPHANED, EndCause.REJECTED,
    EndCause.PREEMPTED, EndCause.BATTERY_CRITICAL})


#: The FailureCause the agent sees (`error(Cause)`) for each end cause; "" = by state.
FAILURE_OF: Mapping[EndCause, str] = {
    EndCause.OPERATOR: "", EndCause.AGENT: "",
    EndCause.LINK_LOST: FailureCause.LINK_DOWN, EndCause.FAILSAFE: FailureCause.FAILSAFE,
    EndCause.ORPHANED: FailureCause.ORPHANED, EndCause.QUARANTINED: FailureCause.QUARANTINED,
    EndCause.RCL_RESTARTED: FailureCause.TRANSIENT, EndCause.REJECTED: FailureCause.REJECTED,
    EndCause.PREEMPTED: FailureCause.PREEMPTED, EndCause.NODE_DOWN: FailureCause.NODE_DOWN,
    EndCause.DECOMMISSIONED: FailureCause.DECOMMISSIONED,
    EndCause.BATTERY_CRITICAL: FailureCause.BATTERY_CRITICAL,
}


# -- events -------------------------------------------------------------------------------
class EventKind(StrEnum):
    ACCEPT = "accept"
    RESTORE = "restore"
    REFINE_FAILED = "refine_failed"
    SKILL_ENDED = "skill_ended"
    VERDICT = "verdict"
    SUSPEND = "suspend"
    RESUME = "resume"
    END = "end"
    STOPPED = "stopped"
    DEADLINE = "deadline"


@dataclass(frozen=True)
class Accept:
    """A new request was accepted (journaled PENDING) for this robot."""

    teleop: bool = False
    held: SuspendCause | None = None  # its goal is suspended already (held_goals.py)
    why: str = ""  # ... or why else it starts held (a stand-down by area)
    kind = EventKind.ACCEPT


@dataclass(frozen=True)
class Restore:
    """Taken back from the journal after a restart (`why`: "an RCL restart", ...)."""

    why: str
    suspended_by: SuspendCause | None = None
    teleop: bool = False
    kind = EventKind.RESTORE


@dataclass(frozen=True)
class RefineFailed:
    """The project's `refine_action` raised (or returned non-skills)."""

    reason: str
    cause: str = ""  # the FailureCause of what it raised (failure_causes.py)
    kind = EventKind.REFINE_FAILED


@dataclass(frozen=True)
class SkillEnded:
    """A skill of the current run ended; `all_ended`: none of them runs any more."""

    all_ended: bool
    kind = EventKind.SKILL_ENDED


@dataclass(frozen=True)
class Verdict:
    """The project's `check_action_status` answer (None: keep running)."""

    state: ActionState | None
    reason: str = ""
    cause: str = ""
    all_ended: bool = False
    kind = EventKind.VERDICT


@dataclass(frozen=True)
class Suspend:
    by: SuspendCause
    reason: str = ""
    kind = EventKind.SUSPEND


@dataclass(frozen=True)
class Resume:
    by: SuspendCause
    teleop: bool = False  # whether the robot is (still) in teleop
    kind = EventKind.RESUME


@dataclass(frozen=True)
class End:
    """Cancel, succeed or fail by command."""

    target: ActionState
    by: EndCause
    reason: str = ""
    cause: str = ""  # a FailureCause; default FAILURE_OF[by], cancelled for a cancel

    @property
    def urgent(self) -> bool:
        """Whether it interrupts a skill inside a critical section (WAITS_FOR_CRITICAL)."""
        return self.by not in WAITS_FOR_CRITICAL

    def failure(self) -> str:
        if self.cause:
            return self.cause
        if self.target is ActionState.SUCCEEDED:
            return ""
        return FAILURE_OF[self.by] or (FailureCause.CANCELLED
                                       if self.target is ActionState.CANCELLED else "")

    kind = EventKind.END


@dataclass(frozen=True)
class Stopped:
    """Every interrupted skill has ended."""

    kind = EventKind.STOPPED


@dataclass(frozen=True)
class DeadlinePassed:
    """The skills ignored their interrupt for `interrupt_timeout`."""

    kind = EventKind.DEADLINE


Event = (Accept | Restore | RefineFailed | SkillEnded | Verdict | Suspend | Resume | End
         | Stopped | DeadlinePassed)


# -- effects ------------------------------------------------------------------------------
@dataclass(frozen=True)
class Run:
    """Refine the action from its progress, start its skills, then publish RUNNING
    (`reason`; a re-announcement if it was RUNNING already). If refining fails, feed
    RefineFailed instead."""

    reason: str


@dataclass(frozen=True)
class Interrupt:
    """Interrupt the running skills and start the stop deadline; with none running,
    feed Stopped. Unless `urgent`, a skill inside a critical section (`Skill.critical`)
    is interrupted when the section ends, and the deadline starts then."""

    urgent: bool = False


@dataclass(frozen=True)
class CheckStatus:
    """Ask the project's `check_action_status`; feed its Verdict."""


@dataclass(frozen=True)
class Abandon:
    """Give up on the skills still running (their resources are released)."""


@dataclass(frozen=True)
class Publish:
    """Transition the action to `state`, journal it (with `suspended_by`), publish it.
    A terminal state also calls `on_action_end` first and forgets the action."""

    state: ActionState
    reason: str = ""
    cause: str = ""
    suspended_by: SuspendCause | None = None


@dataclass(frozen=True)
class Announce:
    """No transition: publish the current state again with a new reason."""

    reason: str
    suspended_by: SuspendCause | None = None


@dataclass(frozen=True)
class ReleaseResources:
    """Give back every resource the action holds or waits for, and drop its marks."""


Effect = Run | Interrupt | CheckStatus | Abandon | Publish | Announce | ReleaseResources


# -- the record ---------------------------------------------------------------------------
@dataclass(frozen=True)
class Stop:
    """A stop in progress: where the action goes once its skills have ended."""

    target: ActionState
    reason: str
    cause: str = ""
    by: SuspendCause | None = None  # for a suspension
    resume_after: bool = False  # a resume arrived meanwhile: run again instead
    urgent: bool = False  # interrupts inside a critical section too (Interrupt.urgent)


@dataclass(frozen=True)
class Lifecycle:
    """One action's place in its lifecycle."""

    phase: Phase
    suspended_by: SuspendCause | None = None
    stop: Stop | None = None

    @classmethod
    def of(cls, state: ActionState, suspended_by: SuspendCause | None = None) -> Lifecycle:
        return cls(Phase.of(state), suspended_by if state is ActionState.SUSPENDED else None)


class IllegalEvent(ActionError):
    """An event the lifecycle has no rule for in the action's phase."""


Step = tuple[Lifecycle, tuple[Effect, ...]]
