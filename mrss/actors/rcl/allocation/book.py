"""Who holds each task addressed to a role: exactly one robot, or nobody while it waits.

One object of the allocator, kept in memory and in the action journal (the `tasks`
table, mrss.actors.rcl.journal), every change committed before it takes effect:
- a task is opened (waiting) before it is bid for by the allocation thread, with its
  action (PENDING on no robot: a restarted requester finds it in its inventory and
  adopts it; a new run fails it); a task decided at once, on the thread that submits
  it, is opened and awarded in one commit (nothing was said of it or started before);
  an award is committed before it is published and before the action on the winner is,
  so after a restart a recorded award is carried out, never decided again
  (`TaskRow.robot` set, no action on that robot yet);
- a holder that is lost (`LOSSES`: its link, its failsafe, its node, a quarantine, the
  operator's decommission, its battery below its critical level) gives the task back:
  it waits again, the robot is added to those that lost it, and its progress goes with
  it to the next holder;
- any other end of the task's action (done, failed, cancelled) closes the task.
"""

from __future__ import annotations

import dataclasses
import threading
from dataclasses import dataclass, field

from mrss.actors.rcl.action import Action
from mrss.actors.rcl.journal import ActionJournal, Requester, TaskRow
from mrss.messages import ActionRequest, FailureCause, build

#: The causes of an action's end that say its robot is lost: the task goes to another.
LOSSES = frozenset({FailureCause.LINK_DOWN, FailureCause.FAILSAFE, FailureCause.NODE_DOWN,
                    FailureCause.QUARANTINED, FailureCause.DECOMMISSIONED,
                    FailureCause.BATTERY_CRITICAL})


@dataclass
class Holding:
    """A task addressed to a role: its request as the agent sent it, and its holder."""

    request: ActionRequest
    requester: Requester
    robot: str = ""  # "": waiting
    lost: list[str] = field(default_factory=list)


class TaskBook:
    """uuid -> Holding of every task addressed to a role, journaled (the module's rules)."""

    def __init__(self, journal: ActionJournal | None) -> None:
        self.journal = journal
        self._held: dict[str, Holding] = {}
        self._lock = threading.Lock()

    def load(self) -> list[TaskRow]:
        """What the journal holds (after a restart); the book is filled from it."""
        rows = self.journal.tasks() if self.journal is not None else []
        with self._lock:
            self._held = {r.uuid: Holding(build(ActionRequest, r.request), r.requester,
                                          r.robot, list(r.lost)) for r in rows}
        return rows

    def opened(self, request: ActionRequest, requester: Requester, why: str = "",
               holder: str = "") -> None:
        """A new task waits (journaled with its action, PENDING on no robot: `why`), or,
        decided at once, is held by `holder` already: opened and awarded in one commit."""
        if self.journal is not None:
            self.journal.open_task(Action(uuid=request.uuid, name=request.name,
                                          args=list(request.args), goal=request.goal,
                                          priority=request.priority, literal=request.literal,
                                          reason=why), _wire(request), requester,
                                   holder=holder)
        with self._lock:
            self._held.setdefault(request.uuid, Holding(request, requester, holder))

    def awarded(self, uuid: str, robot: str) -> None:
        if self.journal is not None:
            self.journal.hold_task(uuid, robot)
        with self._lock:
            if uuid in self._held:
                self._held[uuid].robot = robot

    def lost(self, uuid: str, robot: str) -> Holding | None:
        """`robot` lost the task `uuid` it held: it waits again (None: not a task of it)."""
        with self._lock:
            held = self._held.get(uuid)
            if held is None or held.robot != robot or not robot:
                return None
        if self.journal is not None:
            self.journal.lose_task(uuid, robot)
        with self._lock:
            held.robot = ""
            held.lost.append(robot)
            return dataclasses.replace(held, lost=list(held.lost))

    def closed(self, uuid: str) -> None:
        with self._lock:
            known = self._held.pop(uuid, None)
        if known is not None and self.journal is not None:
            self.journal.close_task(uuid)

    def holder(self, uuid: str) -> str | None:
        """The robot holding `uuid` ("" while it waits; None: no task of this book)."""
        with self._lock:
            held = self._held.get(uuid)
            return None if held is None else held.robot

    def get(self, uuid: str) -> Holding | None:
        with self._lock:
            return self._held.get(uuid)

    def holders(self) -> dict[str, str]:
        """uuid -> holder ("" waiting) of every task."""
        with self._lock:
            return {u: h.robot for u, h in self._held.items()}


def _wire(request: ActionRequest) -> dict[str, object]:
    return {f.name: getattr(request, f.name) for f in dataclasses.fields(request)}
