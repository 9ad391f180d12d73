"""The open tasks addressed to a role, the rounds of bidding, and the award.

One object of the RCL core, with one thread (`allocation`), so each award is one
decision and two awards never race for a robot. Rules:
- a role-addressed request is checked (`Task.of`; some configured robot must have every
  capability it asks for, else it is rejected with a "did you mean") and becomes an
  open task; a duplicate of its uuid re-sends its allocation status;
- a round: the bid of every robot with the capabilities that is available (`refusal`)
  is computed here, from what its actor published (`board.BidBoard`) and its link's
  position and battery, without a round trip; the ranking (`evaluators.BidRanking`)
  picks the winner, deterministically; the winner's actor then bids itself
  (`bids.BidRequest`, after whatever is in its mailbox): unfit now, or silent past
  `bid_timeout`, its own bid replaces the board's and the next-ranked is asked;
- a winner: the task is awarded (a `TaskAllocation` AWARDED with why it won), and the
  request goes on as one addressed to that robot (`award`); no winner: the task waits
  (a `TaskAllocation` WAITING with the reason as an enum, sent when it changes);
- re-allocation: a holder lost (`book.LOSSES`) gives its task back (`reopen`, with
  its progress); it is bid for again, the robots that lost it being unavailable; the
  next award goes out as an AWARDED naming both, and `reassigned` tells the core (the
  agent's `reassigned(Task, From, To)` percept);
- every open, award, loss and end is journaled first (`book.TaskBook`);
- rounds run for every open task, highest priority and then oldest first, when a task
  arrives, whenever a robot's state changes or an action ends (`kick`), and every
  `retry_every` seconds (a robot's battery or position changes without an event).
"""

from __future__ import annotations

import difflib
import logging
import threading
import time
from collections.abc import Callable, Mapping
from dataclasses import dataclass, field
from typing import Any

import pykka

from mrss.actors.rcl.allocation import published
from mrss.actors.rcl.allocation.bids import Bid, BidRequest, Place, compute_bid, no_bid
from mrss.actors.rcl.allocation.board import BidBoard
from mrss.actors.rcl.allocation.book import TaskBook
from mrss.actors.rcl.allocation.evaluators import BidRanking, Choice
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
                 ref: Callable[[str], pykka.ActorRef[Any] | None],
                 board: BidBoard, where: Callable[[str], tuple[Place | None, float | None]],
                 refusal: Callable[[str], str | None],
                 award: Award, publish: Callable[[Message], object],
                 ranking: BidRanking | None = None, bid_timeout: float = 1.0,
                 retry_every: float = 1.0, clock: Callable[[], float] = time.monotonic,
                 book: TaskBook | None = None,
                 reassigned: Reassigned = lambda _r, _f, _t: None) -> None:
        self.profiles = dict(profiles)
        self._ref, self._refusal, self._award, self._publish = ref, refusal, award, publish
        self.board, self._where = board, where
        self.ranking = ranking or BidRanking()
        self.bid_timeout, self.retry_every, self.clock = bid_timeout, retry_every, clock
        self.book = book or TaskBook(None)
        self._reassigned = reassigned
        self._open: dict[str, OpenTask] = {}
        self._bases: dict[str, Place] = {}  # first-seen positions of robots without a base
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
            self._thread.join(timeout=self.bid_timeout + 5.0)

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
        self.book.opened(request, requester,  # journaled before anything is decided
                         f"waiting for {task.describe()}")
        self._open_task(OpenTask(request, requester, task, self.clock()))

    def reopen(self, request: ActionRequest, requester: Any, lost_from: str,
               progress: dict[str, JsonValue]) -> None:
        """A task whose holder was lost (the book has it waiting): bid for it again."""
        self._open_task(OpenTask(request, requester, Task.of(request), self.clock(),
                                 progress=dict(progress), lost_from=lost_from))

    def _open_task(self, open_task: OpenTask) -> None:
        with self._lock:
            self._open[open_task.task.uuid] = open_task
        log.info("task %s %s opened%s: %s", open_task.task.uuid,
                 open_task.request.literal or open_task.request.name,
                 f" again ({open_task.lost_from} lost it)" if open_task.lost_from else "",
                 open_task.task.describe())
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
                try:
                    self._round(open_task)
                except Exception:  # a bug must not stop allocation for every other task
                    log.exception("allocation round for %s failed", open_task.task.uuid)

    def _round(self, open_task: OpenTask) -> None:
        task = open_task.task
        bids = self._bids(task)
        open_task.rounds += 1
        confirmed: set[str] = set()
        while True:
            choice = self.ranking.choose(task, bids)
            winner = choice.winner
            if winner is None:
                break
            if self._refusal(winner.robot) is not None:  # unavailable since: next round
                self._wake.set()
                return
            if winner.robot in confirmed:
                self._awarded(open_task, winner, choice)
                return
            fresh = self._confirm(task, winner.robot)
            confirmed.add(winner.robot)
            if fresh.fit and fresh.preempts <= winner.preempts:
                self._awarded(open_task, winner, choice)
                return
            log.info("task %s: %s's own bid differs from its board's (%s): ranked again",
                     task.uuid, winner.robot, fresh.describe())
            bids = [fresh if b.robot == winner.robot else b for b in bids]
        if open_task.said != (choice.wait, choice.why):
            open_task.said = (choice.wait, choice.why)
            open_task.choice = choice
            self._say_waiting(open_task, choice.wait, choice.why)

    def _bids(self, task: Task) -> list[Bid]:
        """Every capable robot's bid, computed here from the board (no round trip)."""
        bids: list[Bid] = []
        for robot, profile in sorted(self.profiles.items()):
            if not profile.can(task.capabilities):
                continue
            refusal = self._refusal(robot)
            state = self.board.state(robot)
            if refusal is not None or state is None:
                bids.append(no_bid(robot, WaitReason.UNAVAILABLE,
                                   f"unavailable: {refusal or 'its actor is down'}"))
                continue
            position, battery = self._where(robot)
            if position is not None and robot not in self._bases:
                self._bases[robot] = position
            request = BidRequest(task, profile, profile.base or self._bases.get(robot))
            bids.append(compute_bid(request, position=position, battery=battery,
                                    teleop=state.teleop, work=state.work))
        return bids

    def _confirm(self, task: Task, robot: str) -> Bid:
        """The winner's bid from its actor (after whatever is in its mailbox): the
        award's re-validation, one round trip."""
        profile = self.profiles[robot]
        ref = self._ref(robot)
        if ref is None:
            return no_bid(robot, WaitReason.UNAVAILABLE, "unavailable: its actor is down")
        try:
            bid = ref.ask(BidRequest(task, profile, profile.base or self._bases.get(robot)),
                          timeout=self.bid_timeout)
        except pykka.Timeout:
            return no_bid(robot, WaitReason.NO_BID, f"did not bid within {self.bid_timeout:g} s")
        except pykka.ActorDeadError:
            return no_bid(robot, WaitReason.UNAVAILABLE, "unavailable: actor down")
        except Exception as exc:
            log.warning("robot %s could not bid for %s: %r", robot, task.uuid, exc)
            return no_bid(robot, WaitReason.NO_BID, f"could not bid: {exc!r}")
        if not isinstance(bid, Bid):
            return no_bid(robot, WaitReason.NO_BID, f"answered {bid!r}, not a bid")
        return bid

    def _awarded(self, open_task: OpenTask, winner: Bid, choice: Choice) -> None:
        task, request = open_task.task, open_task.request
        with self._lock:
            self._open.pop(task.uuid, None)
        latency = self.clock() - open_task.since
        self.award_latencies.append(latency)
        del self.award_latencies[:-10000]
        log.info("task %s awarded to %s after %d round(s), %.1f ms: %s", task.uuid,
                 winner.robot, open_task.rounds, latency * 1000, choice.why)
        self.book.awarded(task.uuid, winner.robot)  # committed before the action is
        self._send(published.allocation(request, task, choice, evaluator=self.ranking.name,
                                        profiles=self.profiles,
                                        lost_from=open_task.lost_from))
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
