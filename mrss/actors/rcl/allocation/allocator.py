"""The open tasks addressed to a role, the rounds of bidding, and the award.

One object of the RCL core. Each round is one decision taken under the decision lock
(the core's: a round's reading of the robots and its award, which starts the action on
the winner, are one step; nothing the core does, such as starting another action or a
robot becoming unavailable, falls between them), so two awards never race for a robot.
Rules:
- a role-addressed request is checked (`Task.of`; some configured robot must have every
  capability it asks for, else it is rejected with a "did you mean") and becomes an
  open task; a duplicate of its uuid re-sends its allocation status;
- a round: every robot with the capabilities bids, in one pass over the fleet's state
  (`fleet.FleetRound`: the unavailable robots, what their actors published on the bid
  board, their links' position and battery), with no round trip to any actor (the
  board knows at once whatever the core told an actor); the ranking
  (`evaluators.BidRanking`) picks the winner, deterministically;
- a new task is decided at once on the thread that submits it when no other task is
  open (no hand-over to the allocation thread), and a winner is journaled with the
  task in one commit; otherwise, and for every task given back, the allocation thread
  runs the rounds;
- a winner: the task is awarded (a `TaskAllocation` AWARDED with why it won), and the
  request goes on as one addressed to that robot (`award`); no winner: the task waits
  (a `TaskAllocation` WAITING with the reason as an enum, sent when it changes);
- re-allocation: a holder lost (`book.LOSSES`) gives its task back (`reopen`, with
  its progress); it is bid for again, the robots that lost it being unavailable; the
  next award goes out as an AWARDED naming both, and `reassigned` tells the core (the
  agent's `reassigned(Task, From, To)` percept);
- every open, award, loss and end is journaled first (`book.TaskBook`): before it is
  published, before any action starts;
- rounds run for every open task, highest priority and then oldest first, when a task
  arrives, whenever a robot's state changes or an action ends (`kick`), and every
  `retry_every` seconds (a robot's battery or position changes without an event); the
  decision lock is taken per task, never for all of them.
"""

from __future__ import annotations

import difflib
import logging
import threading
import time
from collections.abc import Callable, Mapping
from dataclasses import dataclass, field
from typing import Any

from mrss.actors.rcl.allocation import published
from mrss.actors.rcl.allocation.bids import Bid, Place
from mrss.actors.rcl.allocation.board import BidBoard
from mrss.actors.rcl.allocation.book import TaskBook
from mrss.actors.rcl.allocation.evaluators import BidRanking, Choice
from mrss.actors.rcl.allocation.fleet import FleetRound
from mrss.actors.rcl.allocation.profile import RobotProfile
from mrss.actors.rcl.allocation.task import Task
from mrss.errors import ActionError
from mrss.messages import (
    ActionRequest,
    JsonValue,
    Message,
    WaitReason,
)

log = logging.getLogger("mrss.rcl.allocation")

#: (the request, its requester, the winner, the progress it resumes from)
Award = Callable[[ActionRequest, Any, str, dict[str, JsonValue]], None]
#: (the request, the robot that lost it, the robot it went to)
Reassigned = Callable[[ActionRequest, str, str], None]


@dataclass
class OpenTask:
    """A task not awarded yet: its request, requester, and what was last said of it."""

    request: ActionRequest
    requester: Any
    task: Task
    since: float
    said: tuple[WaitReason, str] | None = None
    rounds: int = 0
    timings: list[float] = field(default_factory=list)
    progress: dict[str, JsonValue] = field(default_factory=dict)  # from a lost holder
    lost_from: str = ""  # the robot that lost it ("": a new task)
    choice: Choice | None = None  # the round's decision it waits on (its bids published)


class Allocator:
    """Open tasks and their rounds of bidding (the rules of the module)."""

    def __init__(self, profiles: Mapping[str, RobotProfile], *,
                 board: BidBoard, where: Callable[[str], tuple[Place | None, float | None]],
                 unavailable: Callable[[], Mapping[str, str]],
                 award: Award, publish: Callable[[Message], object],
                 ranking: BidRanking | None = None,
                 retry_every: float = 1.0, clock: Callable[[], float] = time.monotonic,
                 book: TaskBook | None = None,
                 reassigned: Reassigned = lambda _r, _f, _t: None,
                 decision_lock: Any = None) -> None:
        self.profiles = dict(profiles)
        self._unavailable, self._award, self._publish = unavailable, award, publish
        self.board, self._where = board, where
        self.ranking = ranking or BidRanking()
        self.retry_every, self.clock = retry_every, clock
        self.book = book or TaskBook(None)
        self._reassigned = reassigned
        self._decision = decision_lock if decision_lock is not None else threading.RLock()
        self._open: dict[str, OpenTask] = {}
        self._bases: dict[str, Place] = {}  # first-seen positions of robots without a base
        self._capable: dict[frozenset[str], list[RobotProfile]] = {}  # by what tasks ask
        self._lock = threading.Lock()
        self._wake = threading.Event()
        self._stop = threading.Event()
        self._thread: threading.Thread | None = None
        #: seconds from a task's arrival to its award, newest last (mrss bench allocation)
        self.award_latencies: list[float] = []

    # -- what the core calls -------------------------------------------------------------
    def start(self) -> None:
        self._stop.clear()
        self._thread = threading.Thread(target=self._loop, name="allocation", daemon=True)
        self._thread.start()

    def stop(self) -> None:
        self._stop.set()
        self._wake.set()
        if self._thread is not None:
            self._thread.join(timeout=5.0)

    def submit(self, request: ActionRequest, requester: Any) -> None:
        """Open a task for a role-addressed request (ActionError: reject it)."""
        with self._lock:
            known = self._open.get(request.uuid)
        if known is not None:
            log.info("duplicate role-addressed request %s: still %s", request.uuid,
                     "waiting" if known.said else "open")
            if known.said is not None:
                self._say_waiting(known, *known.said)
            return
        task = Task.of(request)
        self.check_capable(task)
        open_task = OpenTask(request, requester, task, self.clock())
        why = f"waiting for {task.describe()}"
        with self._decision:
            if self._decides_at_once():
                self._first_round(open_task, why)
                return
        self.book.opened(request, requester, why)  # journaled before anything is decided
        self._open_task(open_task)

    def reopen(self, request: ActionRequest, requester: Any, lost_from: str,
               progress: dict[str, JsonValue]) -> None:
        """A task whose holder was lost (the book has it waiting): bid for it again."""
        self._open_task(OpenTask(request, requester, Task.of(request), self.clock(),
                                 progress=dict(progress), lost_from=lost_from))

    def _decides_at_once(self) -> bool:
        """A new task is decided on the thread that submits it when no other task is
        open (nothing goes before it) and the allocation runs (the decision lock held)."""
        with self._lock:
            alone = not self._open
        return alone and self._thread is not None and not self._stop.is_set()

    def _first_round(self, open_task: OpenTask, why: str) -> None:
        """A new task's first round, on the submitting thread under the decision lock:
        a winner is journaled with the task in one commit (the task opened and awarded:
        nothing was said of it nor started before), else the task is journaled waiting."""
        request, requester = open_task.request, open_task.requester
        try:
            choice = self._choose(open_task)
        except Exception:  # a bug: the task waits for the allocation thread's rounds
            log.exception("allocation round for %s failed", open_task.task.uuid)
            self.book.opened(request, requester, why)
            self._open_task(open_task)
            return
        if choice.winner is not None:
            self.book.opened(request, requester, why, holder=choice.winner.robot)
            self._awarded(open_task, choice.winner, choice, journaled=True)
            return
        self.book.opened(request, requester, why)
        self._open_task(open_task, wake=False)
        self._waits(open_task, choice)

    def _open_task(self, open_task: OpenTask, wake: bool = True) -> None:
        with self._lock:
            self._open[open_task.task.uuid] = open_task
        log.info("task %s %s opened%s: %s", open_task.task.uuid,
                 open_task.request.literal or open_task.request.name,
                 f" again ({open_task.lost_from} lost it)" if open_task.lost_from else "",
                 open_task.task.describe())
        if wake:
            self._wake.set()

    def withdraw(self, uuid: str) -> bool:
        """The task's action ended while it waited (cancelled, failed): no more rounds."""
        with self._lock:
            return self._open.pop(uuid, None) is not None

    def check_capable(self, task: Task) -> None:
        """ActionError unless some configured robot has every capability `task` asks."""
        if any(p.can(task.capabilities) for p in self.profiles.values()):
            return
        known = sorted({c for p in self.profiles.values() for c in p.capabilities})
        missing = sorted(task.capabilities - set(known))
        hints = "".join(_did_you_mean(m, known) for m in missing)
        raise ActionError(f"no configured robot has {', '.join(sorted(task.capabilities))}"
                          + (f" (unknown: {', '.join(missing)}{hints})" if missing else
                             f" together (capabilities: {', '.join(known) or 'none'})"),
                          uuid=task.uuid)

    def kick(self) -> None:
        """Something changed (a robot's state, an action ended): run a round soon."""
        self._wake.set()

    def waiting(self) -> dict[str, tuple[WaitReason, str]]:
        """uuid -> (reason, words) of every task waiting now."""
        with self._lock:
            return {u: t.said for u, t in self._open.items() if t.said is not None}

    def is_open(self, uuid: str) -> bool:
        with self._lock:
            return uuid in self._open

    # -- the rounds ------------------------------------------------------------------------
    def _loop(self) -> None:
        while not self._stop.is_set():
            self._wake.wait(self.retry_every)
            self._wake.clear()
            if self._stop.is_set():
                return
            with self._lock:
                tasks = sorted(self._open.values(), key=lambda t: (-t.task.priority, t.since))
            for open_task in tasks:
                if self._stop.is_set():
                    return
                self._decide(open_task)

    def _decide(self, open_task: OpenTask) -> None:
        """One round for `open_task` under the decision lock (awarded, or it waits)."""
        try:
            with self._decision:
                if self.is_open(open_task.task.uuid):  # not decided by another thread
                    self._round(open_task)
        except Exception:  # a bug must not stop allocation for every other task
            log.exception("allocation round for %s failed", open_task.task.uuid)

    def _round(self, open_task: OpenTask) -> None:
        choice = self._choose(open_task)
        if choice.winner is not None:
            self._awarded(open_task, choice.winner, choice)
        else:
            self._waits(open_task, choice)

    def _choose(self, open_task: OpenTask) -> Choice:
        """One round's choice for `open_task` (the decision lock held)."""
        task = open_task.task
        fleet = FleetRound(self._unavailable(), self.board.states(), self._where, self._bases)
        open_task.rounds += 1
        return fleet.choose(task, self._capable_of(task), self.ranking)

    def _waits(self, open_task: OpenTask, choice: Choice) -> None:
        """No winner: the task waits, said when the reason changes."""
        if open_task.said != (choice.wait, choice.why):
            open_task.said = (choice.wait, choice.why)
            open_task.choice = choice
            self._say_waiting(open_task, choice.wait, choice.why)

    def _capable_of(self, task: Task) -> list[RobotProfile]:
        """The profiles of the robots with every capability `task` asks, by robot id."""
        capable = self._capable.get(task.capabilities)
        if capable is None:
            capable = self._capable[task.capabilities] = [
                p for _, p in sorted(self.profiles.items()) if p.can(task.capabilities)]
        return capable

    def _awarded(self, open_task: OpenTask, winner: Bid, choice: Choice,
                 journaled: bool = False) -> None:
        """The award: committed (unless `journaled` with the task already) before it is
        published and before the action on the winner is."""
        task, request = open_task.task, open_task.request
        with self._lock:
            self._open.pop(task.uuid, None)
        if not journaled:
            self.book.awarded(task.uuid, winner.robot)
        latency = self.clock() - open_task.since
        self.award_latencies.append(latency)
        del self.award_latencies[:-10000]
        self._send(published.allocation(request, task, choice, evaluator=self.ranking.name,
                                        profiles=self.profiles,
                                        lost_from=open_task.lost_from))
        log.info("task %s awarded to %s after %d round(s), %.1f ms: %s", task.uuid,
                 winner.robot, open_task.rounds, latency * 1000, choice.why)
        self._award(request, open_task.requester, winner.robot, open_task.progress)
        if open_task.lost_from:
            self._reassigned(request, open_task.lost_from, winner.robot)

    def _say_waiting(self, open_task: OpenTask, wait: WaitReason, why: str) -> None:
        log.info("task %s waits (%s): %s", open_task.task.uuid, wait.value, why)
        choice = open_task.choice or Choice(None, wait, why)
        self._send(published.allocation(open_task.request, open_task.task, choice,
                                        evaluator=self.ranking.name, profiles=self.profiles))

    def _send(self, message: Message) -> None:
        try:
            self._publish(message)
        except Exception as exc:
            log.error("publishing %s failed: %r", message, exc)


def _did_you_mean(word: str, known: list[str]) -> str:
    close = difflib.get_close_matches(word, known, n=1, cutoff=0.7)
    return f"; did you mean {close[0]!r}?" if close else ""
