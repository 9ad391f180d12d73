"""The Robot Communication Layer base a project subclasses (private home).

Projects import `RobotCommLayer` from `mrss.api`: its recipes (an action -> skills), its
action conventions (`action_cb`, `check_action_status`, `on_action_end`,
`resume_after_restart`), how a robot's link is made and closed, and what the RCL
component binds to it (`bind_runtime`, not part of the contract; docs/rcl.md).
"""

from __future__ import annotations

import json
import logging
from collections.abc import Callable, Mapping, Sequence
from contextlib import AbstractContextManager, nullcontext
from pathlib import Path
from typing import Any, ClassVar

from mrss.actors.rcl.action import Action, check_json
from mrss.actors.rcl.allocation.bids import Bid
from mrss.actors.rcl.allocation.task import Task
from mrss.actors.rcl.skill import Skill, SkillOutcome
from mrss.errors import ActionError
from mrss.links.connect import connect_link
from mrss.messages import ActionRequest, ActionState, JsonValue, Message, RobotData
from mrss.options import Option, option_names


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
    #: A project's own ranking of bids for tasks addressed to a role: define a method
    #: `bid_score(self, task, bid) -> float`, lower wins (None: the RCL option
    #: `evaluator`; docs/rcl.md, "Allocation").
    bid_score: Callable[[Task, Bid], float] | None = None

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
        (`mrss.runtime.datalayer_client.DataLayerError`) pass through.
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
