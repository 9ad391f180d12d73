"""Tasks addressed to a role when their robot is lost, and after an RCL restart.

One object of the RCL core, between its action path and the allocator
(mrss.actors.rcl.allocation). Rules:
- the action of a task addressed to a role ends with a cause that says its robot is
  lost (`book.LOSSES`: link lost, failsafe, node down, quarantined, decommissioned,
  battery critical):
  instead of that end, the task goes back to allocation (`lost`). Journaled first: the
  book has it waiting, then the action is PENDING on no robot (its progress kept, the
  reason "reassigning: ..."), published so, and no longer open on the lost robot; the
  allocator bids it out again and the next holder resumes from that progress. The
  agent's intention keeps waiting on the same action; it sees `reassigned(Task, From,
  To)` as a percept when the task has a new holder (`reassigned`);
- a robot whose battery (its link's last `battery` telemetry) is below its
  `battery_critical` is lost for the tasks it holds (`battery_check`, every heartbeat
  tick of the RCL): their actions end with `battery_critical`, which gives them back as
  above (after a critical section of theirs, like a stop of the agent's); a task
  addressed to a robot by name runs on, as before;
- any other end (done, failed for another cause, cancelled) closes the task;
- a task addressed to a robot by name is no task of the book: it ends as before;
- after a restart (`recover`, before the robot actors start) each journaled task has
  one holder or none: a task the journal has waiting is bid for again (its action, if a
  kill came between the book's write and the action's, is taken off the lost robot
  first); a task held by a robot whose action is there stays with it (the actor
  restores it); an award recorded without its action yet is carried out on that robot
  (`carry_out`, after the actors start; when its robot's link has not reported up yet
  since the start, once it does), or, the robot unavailable (or its link silent past
  its timeout), bid for again;
  a task held by a robot that is not configured any more is bid for again (as lost);
  a task whose action ended is closed. After a restart of the whole system (a new
  run) the tasks are closed and their actions (a waiting task's too, journaled when
  it was opened) fail explicitly ("left over from a previous run").
"""

from __future__ import annotations

import dataclasses
import logging
import threading
from collections.abc import Callable
from typing import Any, Protocol

from mrss.actors.rcl import lifecycle as lc
from mrss.actors.rcl.action import Action
from mrss.actors.rcl.allocation.allocator import Allocator
from mrss.actors.rcl.allocation.book import LOSSES
from mrss.actors.rcl.journal import ActionJournal, Requester
from mrss.actors.rcl.open_actions import OpenActions
from mrss.agentspeak.literals import PredicateError, check_literal, quote, symbol, term
from mrss.messages import ActionRequest, ActionState, FailureCause, JsonValue, Percept

log = logging.getLogger("mrss.rcl.allocation")

REASSIGNING = "reassigning"  # how the reason of a task given back starts


class Host(Protocol):
    """What the reallocation asks of the RCL core."""

    def publish_status(self, action: Action, repeat: bool = False) -> None: ...

    def award(self, request: ActionRequest, requester: Any, robot: str,
              progress: dict[str, JsonValue]) -> None: ...

    def refused(self, robot: str) -> bool: ...

    def awaiting(self, robot: str) -> bool: ...

    def control_one(self, uuid: str, event: lc.Suspend | lc.Resume | lc.End) -> None: ...


class Reallocation:
    """Lost holders' tasks back to allocation; the book made whole after a restart."""

    def __init__(self, allocator: Allocator, journal: ActionJournal, actions: OpenActions,
                 host: Host, publish: Any) -> None:
        self.allocator, self.journal, self.actions = allocator, journal, actions
        self.host, self.publish = host, publish
        self._pending: list[tuple[ActionRequest, Requester, str, dict[str, JsonValue]]] = []
        self._carrying = threading.Lock()  # the start, and a robot's first report
        self._low: set[tuple[str, str]] = set()  # (task, robot) handed back for its battery

    # -- the action path ---------------------------------------------------------------------
    def ending(self, action: Action) -> bool:
        """`action` is about to end: True if its task went back to allocation instead (the
        end is then not journaled nor published)."""
        book = self.allocator.book
        if not action.robot or book.holder(action.uuid) != action.robot:
            return False
        if FailureCause(action.cause) not in LOSSES or action.state is not ActionState.FAILED:
            return False
        held = book.lost(action.uuid, action.robot)
        if held is None:
            return False
        with self.actions.lock:
            known = self.actions.get(action.uuid)
        requester = known.requester if known is not None else held.requester
        waiting = self._waiting(action, f"{REASSIGNING}: {action.reason}")
        self.journal.record(waiting, "", requester)
        with self.actions.lock:
            self.actions.drop(action.uuid)
            self.host.publish_status(waiting)
        log.warning("task %s: %s lost it (%s); bidding it out again from %s", action.uuid,
                    action.robot, action.cause, dict(action.progress) or "the start")
        self.allocator.reopen(held.request, requester, action.robot, dict(action.progress))
        return True

    def battery_check(self, battery_of: Callable[[str], float | None]) -> None:
        """Each task held by a robot whose battery is below its `battery_critical` goes
        back to allocation: its action ends with `battery_critical` (a loss), once."""
        held = {(u, r) for u, r in self.allocator.book.holders().items() if r}
        self._low &= held
        for uuid, robot in sorted(held - self._low):
            profile = self.allocator.profiles.get(robot)
            level = battery_of(robot)
            if profile is None or level is None or level >= profile.battery_critical:
                continue
            self._low.add((uuid, robot))
            why = (f"robot {robot}'s battery is at {level:.0f} %, below its critical "
                   f"{profile.battery_critical:g} %")
            log.warning("task %s: %s; it goes to another robot", uuid, why)
            self.host.control_one(uuid, lc.End(ActionState.FAILED,
                                               lc.EndCause.BATTERY_CRITICAL, why))

    def ended(self, action: Action) -> None:
        """`action` ended (journaled): its task, if it is one, is closed."""
        if action.terminal:
            self.allocator.book.closed(action.uuid)
            if self.allocator.withdraw(action.uuid):
                log.info("task %s ended while it waited (%s): no longer bid for",
                         action.uuid, action.state.value)

    def reassigned(self, request: ActionRequest, lost_from: str, to: str) -> None:
        """The agent's percept `reassigned(Task, From, To)`: Task is the action as the
        agent wrote it (its role in place of the robot)."""
        task = request.literal or quote(request.uuid)
        try:
            text = check_literal(f"reassigned({task}, {term(symbol(lost_from))}, "
                                 f"{term(symbol(to))})")
        except PredicateError as exc:
            log.error("task %s: no reassigned percept: %s", request.uuid, exc)
            return
        try:
            self.publish(Percept(literal=text))
        except Exception as exc:
            log.error("publishing %s failed: %r", text, exc)

    # -- restart -------------------------------------------------------------------------------
    def recover(self, new_run: bool) -> set[str]:
        """Make the book whole from the journal (before the robot actors start); the uuids
        of the tasks whose actions are not a robot's (the core leaves them alone)."""
        book = self.allocator.book
        rows = book.load()
        mine: set[str] = set()
        for row in rows:
            entry = self.journal.get(row.uuid)
            held = book.get(row.uuid)
            if new_run or held is None or (entry is not None and entry.action.terminal):
                book.closed(row.uuid)  # ended, or nobody waits for it any more
                continue
            progress = dict(entry.action.progress) if entry is not None else {}
            requester = entry.requester if entry is not None else row.requester
            gone = row.robot and row.robot not in self.allocator.profiles
            if row.robot and entry is not None and entry.action.robot == row.robot \
                    and not gone:
                continue  # held, and its action is there: the robot actor restores it
            if gone:  # its robot is configured no more: as lost, the task goes to another
                log.warning("task %s: its holder %s is not configured after the restart; "
                            "bidding it out again", row.uuid, row.robot)
                book.lost(row.uuid, row.robot)
                row = row._replace(robot="", lost=[*row.lost, row.robot])
            mine.add(row.uuid)
            if row.robot:  # an award recorded, its action not yet: carried out below
                log.info("task %s: its award to %s is carried out after the restart",
                         row.uuid, row.robot)
                self._pending.append((held.request, requester, row.robot, progress))
                continue
            if entry is not None and entry.action.robot:  # killed between book and action
                self.journal.record(self._waiting(entry.action, f"{REASSIGNING}: "
                                                  f"{entry.action.robot} lost it"),
                                    "", requester)
            log.info("task %s waits again after the restart", row.uuid)
            self.allocator.reopen(held.request, requester, row.lost[-1] if row.lost else "",
                                  progress)
        return mine

    def carry_out(self) -> None:
        """The awards recorded before a restart whose actions were not started (after the
        robot actors start): on their robot, or bid for again if it is unavailable now;
        those of a robot whose link has not reported up since the start wait for it
        (called again when it does, or when its wait is over)."""
        with self._carrying:  # each award is taken out once, and carried out once
            waits = [self.host.awaiting(p[2]) for p in self._pending]
            ready = [p for p, wait in zip(self._pending, waits, strict=True) if not wait]
            self._pending = [p for p, wait in zip(self._pending, waits, strict=True) if wait]
        for request, requester, robot, progress in ready:
            if self.host.refused(robot):
                self.allocator.book.lost(request.uuid, robot)
                self.allocator.reopen(request, requester, robot, progress)
            else:
                self.host.award(request, requester, robot, progress)

    @staticmethod
    def _waiting(action: Action, reason: str) -> Action:
        return dataclasses.replace(action, state=ActionState.PENDING, robot="", reason=reason,
                                   cause="", progress=dict(action.progress),
                                   args=list(action.args))

