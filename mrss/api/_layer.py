"""Actions, skills, resources and the Robot Communication Layer base (private home).

Projects import these names from `mrss.api`. What the RCL alone uses (`ACTION_TRANSITIONS`,
`check_action_transition`, `check_json`, `SkillRuntime`, `RobotCommLayer.bind_runtime`)
lives here and is not part of the contract (docs/rcl.md, "Actions" and "Skills").
"""

from __future__ import annotations

import dataclasses
import json
import logging
import threading
from collections.abc import Callable, Mapping, Sequence
from contextlib import AbstractContextManager, nullcontext
from dataclasses import dataclass, field
from enum import StrEnum
from pathlib import Path
from typing import Any, ClassVar, Protocol

from mrss.actors.lifecycle import check_action_transition
from mrss.errors import ActionError, MrssError
from mrss.links.connect import connect_link
from mrss.messages import (
    ActionRequest,
    ActionState,
    JsonValue,
    Message,
    RobotData,
)
from mrss.options import Option, option_names
from mrss.plans import plan_record


def check_json(value: Any, what: str) -> None:
    """Raise ActionError unless `value` can go into the journal and on the bus."""
    try:
        json.dumps(value)
    except (TypeError, ValueError) as exc:
        raise ActionError(f"{what} is not JSON-compatible: {exc}") from None


@dataclass
class Action:
    """An environment action of the agent, as the RCL tracks it."""

    uuid: str
    name: str
    args: list[JsonValue] = field(default_factory=list)
    robot: str = ""
    goal: str = ""
    priority: int = 0
    state: ActionState = ActionState.PENDING
    progress: dict[str, JsonValue] = field(default_factory=dict)
    literal: str = ""
    reason: str = ""
    cause: str = ""  # a FailureCause value once failed for a known cause, else ""

    @property
    def terminal(self) -> bool:
        return self.state.terminal

    def transition(self, new: ActionState, reason: str = "", cause: str = "") -> None:
        """Move to `new` (ActionError if the table forbids it) and record why."""
        check_action_transition(self.state, new, self.uuid)
        self.state = new
        self.reason = reason
        self.cause = cause

    def copy(self) -> Action:
        """An independent snapshot (args and progress copied)."""
        return dataclasses.replace(self, args=list(self.args), progress=dict(self.progress))


@dataclass(frozen=True)
class Resource:
    """A named thing only one action may use at a time (airspace, a camera, a robot's motion).

    With `per_robot`, the name is qualified by the skill's robot: "ugv1/motion".
    """

    name: str
    per_robot: bool = False

    def qualified(self, robot: str) -> str:
        return f"{robot}/{self.name}" if self.per_robot else self.name


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
    """

    #: Resources acquired before `start` and released after `finish`.
    resources: ClassVar[tuple[Resource | str, ...]] = ()
    #: How many times a skill that raised is started again before it fails its action.
    max_restarts: ClassVar[int] = 0
    #: ... within this many seconds (the restart intensity's window).
    restart_period: ClassVar[float] = 60.0

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


class RobotCommLayer:
    """Base of a project's Robot Communication Layer: the recipes and action conventions.

    Methods are called from the RCL's robot actors, one thread per robot: keep shared
    state thread-safe.
    """

    #: Seconds an interrupted skill gets to return before it is abandoned.
    interrupt_timeout: float = 5.0
    #: Keys of a robot's table that the layer reads itself (not link options): names, or
    #: `Option`s that `mrss check` also type-checks; it validates the other keys against
    #: the robot's `link` kind.
    robot_settings: ClassVar[tuple[str | Option, ...]] = ()

    def connect_robot(self, robot: str, options: Mapping[str, Any]) -> Any:
        """The link object skills of `robot` use (`Skill.link`), from its project.toml table.

        Default: the link its `link` key names (mrss.links.connect: simulator addresses
        and the project's broker resolved, `robot_settings` keys set aside), started, its
        telemetry sent to the data layer (`publish_data`) and its state to the RCL
        (`report_link`); None for a table without `link`.
        """
        link = connect_link(robot, options, project_dir=self.project_dir,
                            run_dir=self.run_dir, layer_keys=option_names(self.robot_settings),
                            on_link_state=lambda up, why: self.report_link(robot, up, why),
                            on_telemetry=lambda record: self._forward_telemetry(robot, record))
        set_scope = getattr(link, "set_sample_scope", None)
        if callable(set_scope):
            set_scope(self.sample_scope)
        return link

    def _forward_telemetry(self, robot: str, record: Mapping[str, JsonValue]) -> None:
        self.publish_data(robot, record)

    def sample_scope(self) -> AbstractContextManager[object]:
        """The block a link hands one telemetry sample's records over in: their
        `publish_data` messages leave as one bus message (nothing special unbound)."""
        return self._gather_fn() if self._gather_fn is not None else nullcontext()

    def disconnect_robot(self, robot: str, link: Any) -> None:
        """Close a link made by `connect_robot` (default: its `close()` if it has one)."""
        close = getattr(link, "close", None)
        if callable(close):
            close()

    def refine_action(self, action: Action) -> list[Skill]:
        """The skills that carry out `action` (read `action.progress` to resume)."""
        raise ActionError(f"no recipe for action {action.name!r}", uuid=action.uuid)

    def check_action_status(
        self, action: Action, skill_outcomes: Sequence[SkillOutcome | None],
    ) -> ActionState | None:
        """The action's end state given each skill's outcome (None: still running).

        Default AND: SUCCEEDED when all skills succeeded, FAILED as soon as one did not.
        Return None to keep running.
        """
        if any(o in (SkillOutcome.FAILED, SkillOutcome.INTERRUPTED) for o in skill_outcomes):
            return ActionState.FAILED
        if all(o is SkillOutcome.SUCCEEDED for o in skill_outcomes):
            return ActionState.SUCCEEDED
        return None

    def action_cb(self, request: ActionRequest) -> Action:
        """Turn a request into an Action; default reads `name(robot_id, goal_id, ...)`.

        Explicit `robot`/`goal` fields of the request win over the arguments.
        Raise ActionError to reject a malformed request.
        """
        args = list(request.args)
        robot = request.robot or (args[0] if args else "")
        goal = request.goal or (args[1] if len(args) > 1 else "")
        if not isinstance(robot, str) or not robot:
            raise ActionError(
                f"{request.name}: no robot id (expected {request.name}(robot_id, goal_id, ...))",
                uuid=request.uuid)
        if not isinstance(goal, str):
            goal = json.dumps(goal)
        check_json(args, f"{request.name} arguments")
        return Action(uuid=request.uuid, name=request.name, args=args, robot=robot, goal=goal,
                      priority=request.priority, literal=request.literal)

    def on_action_end(self, action: Action) -> None:
        """Store data about a finished action (called before its end status goes out)."""

    def resume_after_restart(self, action: Action) -> bool:
        """Whether an action left running by a dead RCL is resumed (True) or failed."""
        return True

    # -- what the RCL component binds (all None when the layer runs without a bus) ----------
    #: The project folder and the run folder (broker.url, simulator addresses, ...).
    project_dir: Path | None = None
    run_dir: Path | None = None
    _publish_fn: Callable[[Message], object] | None = None
    _data_fn: Callable[[str, Sequence[Any], float | None], Any] | None = None
    _link_state_fn: Callable[[str, bool, str], object] | None = None
    _link_states: dict[str, tuple[bool, str]] | None = None
    _gather_fn: Callable[[], AbstractContextManager[object]] | None = None

    def bind_runtime(self, *, project_dir: Path | None = None, run_dir: Path | None = None,
                     publish: Callable[[Message], object] | None = None,
                     data_call: Callable[[str, Sequence[Any], float | None], Any] | None = None,
                     link_state: Callable[[str, bool, str], object] | None = None,
                     gather: Callable[[], AbstractContextManager[object]] | None = None,
                     ) -> None:
        """Connect the layer to its RCL (called by RclService; given arguments replace).

        `publish` sends a bus message, `data_call(function, args, timeout)` calls the
        Symbol and Data Layer, `link_state(robot, up, reason)` tells the RCL a robot's
        link went down (it is unavailable and its actions fail with the reason) or came
        back; link states reported before it was bound are replayed to it. Inside a
        `gather()` block what `publish` sends is held and sent together at its end (the
        records of one telemetry sample: `sample_scope`).
        """
        if project_dir is not None:
            self.project_dir = project_dir
        if run_dir is not None:
            self.run_dir = run_dir
        if publish is not None:
            self._publish_fn = publish
        if gather is not None:
            self._gather_fn = gather
        if data_call is not None:
            self._data_fn = data_call
        if link_state is not None:
            self._link_state_fn = link_state
            for robot, (up, reason) in dict(self._link_states or {}).items():
                self._tell_available(robot, up, reason)

    def publish_data(self, robot: str, data: Mapping[str, JsonValue]) -> bool:
        """Send robot data (telemetry, detections) to the data layer as `robot.<id>.data`.

        Returns False when there is no bus or publishing failed (logged); never raises.
        """
        if self._publish_fn is None:
            return False
        try:
            self._publish_fn(RobotData(robot=robot, data=dict(data)))
            return True
        except Exception as exc:
            _log.warning("robot data of %s not published: %r", robot, exc)
            return False

    def data_call(self, function: str, *args: Any, timeout: float | None = 5.0) -> Any:
        """Call a Symbol and Data Layer function (grounding, external functions).

        Raises ActionError without a data layer; the data layer's own errors
        (`mrss.edge.datalayer_client.DataLayerError`) pass through.
        """
        if self._data_fn is None:
            raise ActionError(f"{function}: this RCL has no data layer")
        return self._data_fn(function, list(args), timeout)

    def report_link(self, robot: str, up: bool, reason: str = "") -> None:
        """A robot's link went up or down: down makes the robot unavailable (its open
        actions fail with `reason`, new ones are refused, the reasoner perceives
        `robot_unavailable(R)`), up makes it available again."""
        if self._link_states is None:
            self._link_states = {}
        self._link_states[robot] = (up, reason)
        self._tell_available(robot, up, reason)

    def _tell_available(self, robot: str, up: bool, reason: str) -> None:
        if self._link_state_fn is not None:
            try:
                self._link_state_fn(robot, up, reason)
            except Exception as exc:
                _log.warning("availability of %s not reported: %r", robot, exc)


_log = logging.getLogger("mrss.rcl.layer")
