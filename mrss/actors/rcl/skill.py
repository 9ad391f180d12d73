"""Skills: how a project carries out an action, one skill per thread (private home).

A project's `skills.py` subclasses `Skill`; projects import these names from `mrss.api`.
Here: the skill's states and the one table of their legal transitions, how a skill ends
(`SkillOutcome`), the resources a skill holds one action at a time (`Resource`), a
critical section it is never pre-empted in (`CriticalSection`, `Skill.critical`), and
what the RCL gives a running skill (`SkillRuntime`, internal: not part of the contract;
docs/rcl.md, "Skills").
"""

from __future__ import annotations

import math
import threading
from collections.abc import Iterator, Mapping, Sequence
from contextlib import contextmanager
from dataclasses import dataclass
from enum import StrEnum
from typing import Any, ClassVar, Protocol

from mrss.actors.rcl.action import Action, check_json
from mrss.errors import ActionError, MrssError
from mrss.messages import JsonValue
from mrss.messages.plans import plan_record


@dataclass(frozen=True)
class Resource:
    """A named thing only one action may use at a time (airspace, a camera, a robot's motion).

    With `per_robot`, the name is qualified by the skill's robot: "ugv1/motion".
    """

    name: str
    per_robot: bool = False

    def qualified(self, robot: str) -> str:
        return f"{robot}/{self.name}" if self.per_robot else self.name


@dataclass(frozen=True)
class CriticalSection:
    """A stretch of a skill that must not be cut (a landing, an arm retracting): its name
    and the most seconds it may last (`bound`). Past the bound it no longer defers a
    stop, the RCL logs it and the chaos checker counts it as a violation."""

    name: str
    bound: float

    def __post_init__(self) -> None:
        if not isinstance(self.name, str) or not self.name:
            raise ActionError(f"a critical section needs a name, not {self.name!r}")
        if isinstance(self.bound, bool) or not isinstance(self.bound, (int, float)) \
                or not math.isfinite(self.bound) or self.bound <= 0:
            raise ActionError(f"critical section {self.name!r}: bound must be a number "
                              f"of seconds > 0, not {self.bound!r}")


class SkillState(StrEnum):
    """States of a skill (paper IV-E)."""

    START = "start"
    RUN = "run"
    INTERRUPT = "interrupt"
    FINISH = "finish"


#: The one table of legal skill transitions. FINISH -> START is a restart after a crash.
SKILL_TRANSITIONS: Mapping[SkillState, frozenset[SkillState]] = {
    SkillState.START: frozenset({SkillState.RUN, SkillState.INTERRUPT, SkillState.FINISH}),
    SkillState.RUN: frozenset({SkillState.INTERRUPT, SkillState.FINISH}),
    SkillState.INTERRUPT: frozenset({SkillState.FINISH}),
    SkillState.FINISH: frozenset({SkillState.START}),
}


class SkillOutcome(StrEnum):
    """How a skill ended."""

    SUCCEEDED = "succeeded"
    FAILED = "failed"
    INTERRUPTED = "interrupted"


class SkillInterrupted(MrssError):
    """Raised inside a skill by `acquire` when the skill is interrupted while it waits."""


class SkillRuntime(Protocol):
    """What the RCL gives a running skill (internal; projects use Skill's methods)."""

    action: Action
    link: Any
    interrupt_event: threading.Event

    def record_progress(self, values: Mapping[str, JsonValue]) -> None: ...

    def acquire(self, resource: str, timeout: float | None) -> None: ...

    def release(self, resource: str) -> None: ...

    def publish_data(self, data: Mapping[str, JsonValue]) -> bool: ...

    def enter_critical(self, section: CriticalSection) -> None: ...

    def leave_critical(self) -> None: ...


class Skill:
    """Base of project skills: implement `run`, and `start`, `finish`, `terminate` as needed.

    The RCL calls `start()`, then `run()` once on the skill's own thread, then
    `finish(outcome)`. `run` may block on the robot link; it returns None or True
    (succeeded), False or a SkillOutcome. An exception fails the skill with its message
    (after up to `max_restarts` re-runs from START within `restart_period` seconds, by
    the supervision policy: backoff with jitter, a `sup.restart` event each, then
    `sup.escalate` and the action fails). To interrupt (suspend, cancel, pre-emption)
    the RCL sets `interrupted` and calls `terminate()` from another thread: stop the
    robot there so `run` returns soon. Whatever `run` returns then, the outcome is
    INTERRUPTED. Progress recorded with `record_progress` is kept across suspension and
    restarts, and given back through `action.progress` when the action is refined again.

    Inside `with self.critical("landing", bound=30.0):` the skill is not interrupted by a
    pre-emption, a suspension, a cancel or a verdict: they wait until the section ends,
    then apply. A teleop (the operator's emergency stop) and a robot lost (link down,
    failsafe, node down) still interrupt inside it; so does anything once the section
    has lasted longer than its bound.
    """

    #: Resources acquired before `start` and released after `finish`.
    resources: ClassVar[tuple[Resource | str, ...]] = ()
    #: How many times a skill that raised is started again before it fails its action.
    max_restarts: ClassVar[int] = 0
    #: ... within this many seconds (the restart intensity's window).
    restart_period: ClassVar[float] = 60.0
    #: The longest a running skill goes without news (a recorded progress or a new state
    #: of its action) while its robot is not stuck, in seconds; None: no promise. The RCL
    #: publishes its action's bound (`progress_bound_of`) with the RUNNING status;
    #: `mrss chaos` holds the action to it (no-robot-stuck).
    progress_bound: ClassVar[float | None] = None

    _runtime: SkillRuntime | None = None
    _progress: dict[str, JsonValue]
    state: SkillState = SkillState.START
    outcome: SkillOutcome | None = None
    reason: str = ""

    # -- to implement --------------------------------------------------------------
    def start(self) -> None:
        """Prepare (acquire resources, read progress, send the first command)."""

    def run(self) -> SkillOutcome | bool | None:
        """Do the work; may block. None/True: succeeded, False: failed."""
        raise NotImplementedError(f"{type(self).__name__}.run")

    def finish(self, outcome: SkillOutcome) -> None:
        """Clean up after the skill ended with `outcome`."""

    def terminate(self) -> None:
        """Make a blocked `run` return now (called from another thread on interrupt)."""

    # -- given -----------------------------------------------------------------------
    @property
    def name(self) -> str:
        return type(self).__name__

    @property
    def action(self) -> Action:
        """The action this skill belongs to (a snapshot taken when it was refined)."""
        return self._rt().action

    @property
    def robot(self) -> str:
        return self._rt().action.robot

    @property
    def link(self) -> Any:
        """The robot's link object (whatever the project's robot link is), or None."""
        return self._rt().link

    @property
    def progress(self) -> Mapping[str, JsonValue]:
        """The action's progress so far: kept across suspension, resume and restarts."""
        self._rt()
        return self._progress

    @property
    def interrupted(self) -> bool:
        return self._rt().interrupt_event.is_set()

    def record_progress(self, **values: JsonValue) -> None:
        """Remember progress (e.g. `waypoint=3`); journaled, survives suspension/restarts."""
        check_json(values, f"{self.name} progress")
        self._progress.update(values)
        self._rt().record_progress(values)

    def publish_data(self, **record: JsonValue) -> bool:
        """Send a robot data record of this skill's robot (`robot.<id>.data`), as the
        robot's link does with telemetry. False if it could not be sent (logged)."""
        check_json(record, f"{self.name} data")
        return self._rt().publish_data(record)

    def publish_plan(self, waypoints: Sequence[Sequence[float]], reached: int) -> bool:
        """Show the path this skill follows on the dashboard's map: `waypoints` as
        [lat, lon], the first `reached` of them done. Send it when the plan starts and
        when a waypoint is reached (not at telemetry rate); the RCL clears it when the
        action ends (`publish_plan([], 0)` clears it sooner)."""
        action = self.action
        return self._rt().publish_data(plan_record(action.uuid, waypoints, reached,
                                                   action.goal))

    def wait(self, seconds: float) -> bool:
        """Sleep up to `seconds`, waking early on interrupt; True when interrupted."""
        return self._rt().interrupt_event.wait(seconds)

    @contextmanager
    def critical(self, name: str, bound: float) -> Iterator[CriticalSection]:
        """A critical section: until the block ends (at most `bound` seconds), stops that
        can wait (pre-emption, suspension, cancel) wait for it; the action's status says so
        (`critical`, `critical_bound`, `deferring`). Raises SkillInterrupted when the
        skill is interrupted already (nothing of the block runs); sections do not nest."""
        section = CriticalSection(name, bound)
        runtime = self._rt()
        runtime.enter_critical(section)
        try:
            yield section
        finally:
            runtime.leave_critical()

    def acquire(self, resource: Resource | str, timeout: float | None = None) -> None:
        """Wait until this action holds `resource` (pre-empting lower-priority holders).

        Raises SkillInterrupted if the skill is interrupted while waiting, ActionError
        when `timeout` passes first.
        """
        self._rt().acquire(self.resource_name(resource), timeout)

    def release(self, resource: Resource | str) -> None:
        """Give `resource` back (all are released when the skill finishes anyway)."""
        self._rt().release(self.resource_name(resource))

    def resource_name(self, resource: Resource | str) -> str:
        if isinstance(resource, Resource):
            return resource.qualified(self.robot)
        return resource

    def _rt(self) -> SkillRuntime:
        if self._runtime is None:
            raise ActionError(f"skill {self.name} is not running under an RCL")
        return self._runtime

    def _bind(self, runtime: SkillRuntime) -> None:
        """Attach the skill to its runtime (called by the RCL before `start`)."""
        self._runtime = runtime
        self._progress = dict(runtime.action.progress)
        self.state, self.outcome, self.reason = SkillState.START, None, ""

    def _set_state(self, new: SkillState) -> None:
        """Move to `new`; ActionError if SKILL_TRANSITIONS forbids it."""
        if new not in SKILL_TRANSITIONS[self.state]:
            raise ActionError(f"skill {self.name}: illegal transition {self.state} -> {new}")
        self.state = new


def progress_bound_of(skills: list[Skill]) -> float:
    """The progress bound of an action run by `skills` (all at once), seconds; 0: none.

    News of the action comes from whichever skill still runs, so only a promise every one
    of them makes holds for the action: the loosest bound when each declares one, else
    none (a skill without a bound may run on in silence after the bounded ones ended)."""
    bounds = [s.progress_bound for s in skills]
    if not bounds or any(b is None or not b > 0 for b in bounds):
        return 0.0
    return float(max(b for b in bounds if b is not None))
