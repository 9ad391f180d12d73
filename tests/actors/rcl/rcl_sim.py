"""A tiny simulated robot (the physical robot's fake), real skills and a recipe layer for tests.

`SimRobot` is an in-process link object: `goto` blocks like a real motion command until
the test lets the robot arrive (`arrive(n)`), or, with `auto=True`, arrives at once;
`halt()` aborts motion and stays in force until the next `resume_motion()`.
"""

from __future__ import annotations

import sqlite3
import threading
from collections.abc import Callable
from contextlib import closing
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from mrss.actors.rcl.core import RclCore
from mrss.actors.rcl.journal import ActionJournal
from mrss.api import Action, Resource, RobotCommLayer, Skill
from mrss.messages import ActionStatus, AllocationState, Message, TaskAllocation


class SimRobot:
    """A simulated robot: position, waypoint motion, halt."""

    def __init__(self, name: str, auto: bool = False) -> None:
        self.name = name
        self.auto = auto
        self.position: object = None
        self.visited: list[object] = []
        self.halts = 0
        self._cond = threading.Condition()
        self._allowance = 0
        self._halted = False
        self.moving_to: object = None

    def arrive(self, n: int = 1) -> None:
        """Let the robot finish `n` more motions."""
        with self._cond:
            self._allowance += n
            self._cond.notify_all()

    def goto(self, waypoint: object) -> bool:
        """Move to `waypoint`; False when halted on the way."""
        with self._cond:
            self.moving_to = waypoint
            while not (self.auto or self._allowance > 0 or self._halted):
                self._cond.wait()
            self.moving_to = None
            if self._halted:
                return False
            if not self.auto:
                self._allowance -= 1
            self.position = waypoint
            self.visited.append(waypoint)
            return True

    def halt(self) -> None:
        with self._cond:
            self._halted = True
            self.halts += 1
            self._cond.notify_all()

    def resume_motion(self) -> None:
        with self._cond:
            self._halted = False

    def is_moving_to(self, waypoint: object) -> bool:
        with self._cond:
            return self.moving_to == waypoint


class Patrol(Skill):
    """Visit waypoints in order, from the last one reached (progress `waypoint`)."""

    def __init__(self, waypoints: list[object]) -> None:
        self.waypoints = waypoints

    def start(self) -> None:
        self.link.resume_motion()

    def run(self) -> bool:
        index = int(self.progress.get("waypoint", 0))  # type: ignore[arg-type]
        while index < len(self.waypoints):
            if self.interrupted or not self.link.goto(self.waypoints[index]):
                return False
            index += 1
            self.record_progress(waypoint=index)
        return True

    def terminate(self) -> None:
        self.link.halt()


class Crash(Skill):
    """Raises on every run (up to `fail_times`, then succeeds)."""

    def __init__(self, message: str, fail_times: int = 1_000_000, restarts: int = 0) -> None:
        self.message = message
        self.fail_times = fail_times
        self.runs = 0
        self.max_restarts = restarts  # type: ignore[misc]

    def run(self) -> None:
        self.runs += 1
        if self.runs <= self.fail_times:
            raise RuntimeError(self.message)


class Refuse(Skill):
    """Ends FAILED with a reason, without raising."""

    def run(self) -> bool:
        self.reason = "target out of reach"
        return False


class Hold(Skill):
    """Holds a resource and moves to one waypoint; the robot is halted on interrupt."""

    def __init__(self, resource: str, waypoint: object) -> None:
        self.resources = (Resource(resource),)  # type: ignore[misc]
        self.waypoint = waypoint

    def start(self) -> None:
        self.link.resume_motion()

    def run(self) -> bool:
        return bool(self.link.goto(self.waypoint))

    def terminate(self) -> None:
        self.link.halt()


class Stubborn(Skill):
    """Ignores interrupts until released: tests abandonment."""

    def __init__(self, release: threading.Event) -> None:
        self.release_event = release

    def run(self) -> None:
        self.release_event.wait()


class Layer(RobotCommLayer):
    """Recipes for the tests; remembers ended actions."""

    interrupt_timeout = 2.0

    def __init__(self) -> None:
        self.ended: list[Action] = []
        self.refined: list[Action] = []
        self.recipes: dict[str, Callable[[Action], list[Skill]]] = {
            "patrol": lambda a: [Patrol(list(a.args[2]))],  # type: ignore[arg-type]
            "crash": lambda a: [Crash(str(a.args[2]))],
            "flaky": lambda a: [Crash("flaky motor", fail_times=2, restarts=2)],
            "refuse": lambda a: [Refuse()],
            "hold": lambda a: [Hold(str(a.args[2]), a.args[3])],
            "noop": lambda a: [],
        }

    def refine_action(self, action: Action) -> list[Skill]:
        self.refined.append(action)
        recipe = self.recipes.get(action.name)
        if recipe is None:
            return super().refine_action(action)
        return recipe(action)

    def on_action_end(self, action: Action) -> None:
        self.ended.append(action)


class Statuses:
    """The publish side of an RCL under test: records every ActionStatus in order."""

    def __init__(self, check: Callable[[ActionStatus], None] | None = None,
                 check_award: Callable[[TaskAllocation], None] | None = None) -> None:
        self.lock = threading.Lock()
        self.items: list[ActionStatus] = []
        self.others: list[Message] = []
        self.check = check
        self.check_award = check_award
        self.check_failures: list[str] = []

    def __call__(self, message: Message) -> None:
        if isinstance(message, ActionStatus):
            if self.check is not None:
                try:
                    self.check(message)
                except AssertionError as exc:
                    self.check_failures.append(str(exc))
            with self.lock:
                self.items.append(message)
        else:
            if isinstance(message, TaskAllocation) and self.check_award is not None \
                    and message.state is AllocationState.AWARDED:
                try:
                    self.check_award(message)
                except AssertionError as exc:
                    self.check_failures.append(str(exc))
            with self.lock:
                self.others.append(message)

    def of(self, uuid: str) -> list[ActionStatus]:
        with self.lock:
            return [s for s in self.items if s.uuid == uuid]

    def states(self, uuid: str) -> list[str]:
        return [s.state for s in self.of(uuid)]

    def last(self, uuid: str) -> ActionStatus | None:
        found = self.of(uuid)
        return found[-1] if found else None

    def reached(self, uuid: str, state: str) -> Callable[[], bool]:
        def cond() -> bool:
            last = self.last(uuid)
            return last is not None and last.state == state
        return cond


def request_fields(uuid: str, name: str, robot: str, goal: str, *extra: Any,
                   priority: int = 0) -> dict[str, Any]:
    """An action.request body in the default `name(robot_id, goal_id, ...)` shape."""
    return {"uuid": uuid, "name": name, "args": [robot, goal, *extra], "priority": priority}


@dataclass
class RclEnv:
    """An RCL under test and everything around it; `start()` may be called again after
    `stop()` to play a restart on the same journal."""

    journal_path: Path
    robots: dict[str, SimRobot]
    layer: Layer = field(default_factory=Layer)
    statuses: Statuses = field(default_factory=Statuses)
    core: RclCore | None = None
    journal: ActionJournal | None = None
    check_journal_first: bool = True
    now: float = 1000.0  # the core's clock (orphan grace); tests move it on by hand

    def start(self, robots: dict[str, SimRobot] | None = None, new_run: bool = False,
              before_start: Callable[[RclCore], object] = lambda core: None,
              **options: Any) -> RclCore:
        """`before_start(core)` runs between the core's making and its start (as
        RclService binds the links' states there)."""
        self.journal = ActionJournal(self.journal_path)
        self.statuses.check = self._journaled_before_publish if self.check_journal_first else None
        self.statuses.check_award = self._award_journaled_before_publish \
            if self.check_journal_first else None
        links = robots if robots is not None else self.robots
        self.core = RclCore(self.layer, self.journal, self.statuses, links,
                            clock=lambda: self.now, **options)
        before_start(self.core)
        self.core.start(new_run=new_run)
        return self.core

    def stop(self) -> None:
        if self.core is not None:
            self.core.stop()
            self.core = None
        if self.journal is not None:
            self.journal.close()
            self.journal = None

    def _award_journaled_before_publish(self, award: TaskAllocation) -> None:
        """At publish time, a separate connection must already see the award committed
        (the task held by the robot it was awarded to)."""
        with closing(sqlite3.connect(str(self.journal_path))) as db:
            row = db.execute("SELECT robot FROM tasks WHERE uuid=?", (award.uuid,)).fetchone()
        assert row is not None and row[0] == award.robot, (
            f"{award.uuid} awarded to {award.robot} before the journal had it (it says "
            f"{row[0] if row else 'no task'!r})")

    def _journaled_before_publish(self, status: ActionStatus) -> None:
        """At publish time, a separate connection must already see the committed row."""
        reader = ActionJournal(self.journal_path)
        try:
            entry = reader.get(status.uuid)
            assert entry is not None, f"{status.uuid} published before it was journaled"
            assert entry.action.state.value == status.state, (
                f"{status.uuid} published {status.state} but the journal says "
                f"{entry.action.state.value}")
            assert reader.transitions(status.uuid)[-1][0].value == status.state
        finally:
            reader.close()
