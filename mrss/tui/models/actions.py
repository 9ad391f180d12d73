"""The actions as the TUI knows them: requests (name, goal) and their latest status.

A request is seen on the reliable `action` channel (`ActionRequest`), statuses on
`action.status`; either may come first (the TUI may start late and see statuses only).
The model keeps at most `limit` actions, forgetting the oldest finished ones first.
Those addressed to a role are tasks too: their allocation is `tasks` (`models/tasks.py`,
by the same uuid).
"""

from __future__ import annotations

import itertools
from dataclasses import dataclass, field
from typing import Any

from mrss.messages import ActionRequest, ActionState, ActionStatus
from mrss.tui.models.tasks import TasksModel


@dataclass(frozen=True)
class Transition:
    """One line of an action's history: when, what it became, who said so, and why."""

    ts: float
    state: str
    who: str
    why: str = ""


HISTORY_LIMIT = 50  # transitions kept per action


@dataclass
class ActionView:
    """One action: what was asked and where it stands."""

    uuid: str
    seq: int  # order first heard of; the table shows the newest first
    name: str = ""
    args: list[Any] = field(default_factory=list)
    robot: str = ""
    goal: str = ""
    state: str = ""
    reason: str = ""
    cause: str = ""  # the failure cause of its latest status (FailureCause), if any
    progress: dict[str, Any] = field(default_factory=dict)
    updated: float = 0.0
    requester: str = ""
    priority: int | None = None
    literal: str = ""
    history: list[Transition] = field(default_factory=list)

    def add_history(self, entry: Transition) -> None:
        self.history.append(entry)
        del self.history[:-HISTORY_LIMIT]

    def waiting_for(self) -> str:
        """The resource a running action's skill waits for ("" : none); the RCL says it
        in the action's progress (`queued_for`) until the resource is granted."""
        value = self.progress.get(QUEUED_FOR)
        return value if self.state == ActionState.RUNNING and isinstance(value, str) else ""

    def behind(self) -> list[str]:
        """The uuids of the actions it waits behind (holders first)."""
        value = self.progress.get(BEHIND)
        return [u for u in value.split(",") if u] if isinstance(value, str) else []

    @property
    def shown_state(self) -> str:
        """Its state for the operator: "queued" while it waits for its resource (the
        RCL's state is running, but nothing moves yet), else the RCL's state."""
        return "queued" if self.waiting_for() else self.state

    @property
    def terminal(self) -> bool:
        return self.state in {s.value for s in ActionState if s.terminal}

    def progress_text(self, width: int = 40) -> str:
        """`4/12 ███░░░░░░░` when the progress has a known count (`waypoint`/`waypoints`,
        `leg`/`of`, `done`/`total`, `step`/`steps`), then the other `key=value` pairs;
        cut to `width` characters."""
        parts, used = [], {QUEUED_FOR, BEHIND}
        for done_key, total_key in COUNTS:
            done, total = self.progress.get(done_key), self.progress.get(total_key)
            if isinstance(done, int) and isinstance(total, int) and _count(done) \
                    and _count(total) and total > 0:
                parts.append(f"{done}/{total} {bar(done / total)}")
                used |= {done_key, total_key}
                break
        parts += [f"{k}={_short(v)}" for k, v in self.progress.items() if k not in used]
        text = " ".join(parts)
        return text if len(text) <= width else text[: width - 1] + "…"

    def age(self, now: float) -> float | None:
        """Seconds since the latest news of this action."""
        return max(0.0, now - self.updated) if self.updated else None


# the progress keys the RCL sets while an action waits for a resource
# (mrss.actors.rcl.skill_actor: the dashboard does not import the components)
QUEUED_FOR, BEHIND = "queued_for", "behind"
# (done, total) progress keys the table draws as a bar, the first pair present wins
COUNTS = (("waypoint", "waypoints"), ("leg", "of"), ("done", "total"), ("step", "steps"))
BAR_WIDTH = 10


def bar(fraction: float, width: int = BAR_WIDTH) -> str:
    """A text progress bar: `bar(0.25, 8)` is `██░░░░░░`."""
    filled = round(max(0.0, min(1.0, fraction)) * width)
    return "█" * filled + "░" * (width - filled)


class ActionsModel:
    """Actions by uuid; `newest_first()` for the table."""

    def __init__(self, limit: int = 1000) -> None:
        self.limit = limit
        self.actions: dict[str, ActionView] = {}
        self.tasks = TasksModel()  # the allocation of those addressed to a role
        self._seq = itertools.count()

    def _action(self, uuid: str) -> ActionView:
        view = self.actions.get(uuid)
        if view is None:
            view = self.actions[uuid] = ActionView(uuid, next(self._seq))
            if len(self.actions) > self.limit:
                self._forget_oldest()
        return view

    def apply_request(self, request: ActionRequest, ts: float, src: str = "") -> None:
        view = self._action(request.uuid)
        view.name, view.args, view.goal = request.name, list(request.args), request.goal
        view.robot = request.robot or view.robot
        view.priority, view.literal = request.priority, request.literal
        if src and not view.requester:
            view.requester = src
            view.add_history(Transition(ts, "requested", src, request.literal))
        if not view.state:
            view.state = "requested"
        view.updated = max(view.updated, ts)

    def apply_status(self, status: ActionStatus, ts: float, src: str = "") -> None:
        """A transition, or a repeat (progress, snapshot, reconciliation): both say where
        the action stands now; a repeat also names an action whose request went by
        before the dashboard attached."""
        view = self._action(status.uuid)
        if not status.repeat or status.state != view.state:
            why = status.reason + (f" (cause {status.cause})" if status.cause else "")
            view.add_history(Transition(ts, status.state, src, why))
        view.state, view.reason = status.state, status.reason
        view.cause = str(status.cause or "")
        view.progress = dict(status.progress)
        view.robot = status.robot or view.robot
        view.name = view.name or status.name
        view.goal = view.goal or status.goal
        view.updated = ts

    def note(self, uuid: str, ts: float, who: str, why: str) -> None:
        """Something the dashboard did to an action (a debug key), in its history."""
        view = self.actions.get(uuid)
        if view is not None:
            view.add_history(Transition(ts, "note", who, why))

    def newest_first(self) -> list[ActionView]:
        return sorted(self.actions.values(), key=lambda a: a.seq, reverse=True)

    def _forget_oldest(self) -> None:
        """Make room for a tenth of `limit` at once: finished actions go first, oldest first."""
        keep = max(1, self.limit - self.limit // 10)
        order = sorted(self.actions.values(), key=lambda a: (not a.terminal, a.seq))
        for view in order[: len(self.actions) - keep]:
            del self.actions[view.uuid]


def _count(value: Any) -> bool:
    return isinstance(value, int) and not isinstance(value, bool) and value >= 0


def _short(value: Any) -> str:
    if isinstance(value, float):
        return f"{value:.3g}"
    return str(value)
