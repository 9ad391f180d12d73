"""The Robot Communication Layer core: accept actions, route them to robot actors, report.

One idea in one module (~450 lines): accepting, journaling and routing an action under
one lock; what is not that lives in its collaborators (requesters.py, availability.py,
observers.py, open_actions.py) and the lifecycle rules in lifecycle.py.

Transport-free on purpose: requests come in through `submit` / `submit_fields`, goal
management through `control`, and statuses leave through the injected `publish` callable,
so the same object runs in-process in tests and behind the bus (`RclService`). Rules:
- a request is validated by the project's `action_cb`; a malformed one (or one for a
  robot it does not have) is FAILED at once, its reason in the status and counted in a
  `RejectionLog` ("action request": logged once per requester and kind of reason per
  interval, never once per request);
- a uuid is accepted once (journal-backed): a duplicate only re-sends the last status;
- every status is committed to the ActionJournal before it is published;
- on `start`, every non-terminal action of the journal is resumed or explicitly failed;
- robot actors run under an ActorSupervisor (mrss.supervision): a crashed one is
  restarted and takes its actions back from the journal; more than `max_robot_restarts`
  in `restart_period` seconds quarantines the robot: its open actions fail, new ones are
  refused until `probation` has passed (the sup.quarantine / sup.release events go out);
- a terminal status is final: nothing is journaled or published for that uuid after it;
- reconciliation: an `ActionQuery` is answered from the journal, one status per known
  uuid, so a status lost on the bus is asked for again and never wedges a latch;
- a goal suspended by goal management stays suspended: an action requested for it
  before it is resumed starts SUSPENDED (mrss/actors/rcl/held_goals.py);
- adoption: when a requester restarts, what its dead incarnation left open keeps
  running for `adopt_grace` seconds (suspended ones `adopt_grace_suspended`); the new
  incarnation adopts an action by requesting its uuid again (it learns them from the
  `ActionInventory` answer to its query). What nobody adopts in time is cancelled
  ("orphaned"), so no robot works for an intention that is gone.
"""

from __future__ import annotations

import dataclasses
import functools
import logging
import re
import time
from collections.abc import Callable, Mapping
from typing import Any

import pykka

from mrss.actors.rcl import controls
from mrss.actors.rcl import lifecycle as lc
from mrss.actors.rcl.action import Action, check_json
from mrss.actors.rcl.allocation.allocator import Allocator
from mrss.actors.rcl.allocation.bids import Work
from mrss.actors.rcl.allocation.bids import link_state as bid_link_state
from mrss.actors.rcl.allocation.board import BidBoard
from mrss.actors.rcl.allocation.book import TaskBook
from mrss.actors.rcl.allocation.evaluators import BidRanking
from mrss.actors.rcl.allocation.profile import RobotProfile
from mrss.actors.rcl.availability import RobotAvailability
from mrss.actors.rcl.held_goals import HeldGoals
from mrss.actors.rcl.journal import NOBODY, ActionJournal, JournalEntry, Requester
from mrss.actors.rcl.layer import RobotCommLayer
from mrss.actors.rcl.observers import ObserverReports
from mrss.actors.rcl.open_actions import OpenActions
from mrss.actors.rcl.options import default
from mrss.actors.rcl.orphans import Orphans
from mrss.actors.rcl.progress_feed import ProgressFeed
from mrss.actors.rcl.reallocation import Reallocation
from mrss.actors.rcl.requesters import Requesters
from mrss.actors.rcl.resources import ResourceBroker
from mrss.actors.rcl.robot import Control, RobotActor, StartAction
from mrss.actors.rcl.stand_down import StandDowns
from mrss.edge.rejections import RejectionLog
from mrss.errors import ActionError, DecodeError
from mrss.messages import (
    ActionControl,
    ActionRequest,
    ActionState,
    ActionStatus,
    ControlCommand,
    ControlTarget,
    FailureCause,
    JsonValue,
    Message,
    build,
)
from mrss.messages.plans import PlanBoard
from mrss.supervision import (
    ActorContext,
    ActorSupervisor,
    OnExceeded,
    SupervisorSpec,
    actor_child,
)

log = logging.getLogger("mrss.rcl")

Publish = Callable[[Message], object]



def reason_kind(reason: str) -> str:
    """What a refusal is counted as: its reason up to the first quoted value or detail
    ("unknown robot 'ghost7' (known: ...)" -> "unknown robot")."""
    return re.split(r"[:'\"(]", reason, maxsplit=1)[0].strip() or reason[:40]


class RclCore:
    """Accepts ActionRequests and ActionControls; emits ActionStatus via journal + publish.

    Three collaborators hold the rest, each with its own state: `requesters`
    (duplicates, adoption, orphans, reconciliation), `availability` (robots available or
    not, teleop, links, nodes) and `observers` (progress, snapshots); they share the open
    actions (`OpenActions`) and reach robot actors through the core (`Routes`)."""

    def __init__(self, layer: RobotCommLayer, journal: ActionJournal, publish: Publish,
                 robots: Mapping[str, Any], *,
                 max_robot_restarts: int = default("max_robot_restarts"),
                 restart_period: float = default("restart_period"),
                 probation: float = default("probation"),
                 robot_watchdog: float | None = 30.0,
                 adopt_grace: float = default("adopt_grace"),
                 adopt_grace_suspended: float = default("adopt_grace_suspended"),
                 preempted_timeout: float = default("preempted_timeout"),
                 progress_every: float = 0.0,
                 profiles: Mapping[str, RobotProfile] | None = None,
                 ranking: BidRanking | None = None,
                 clock: Callable[[], float] = time.monotonic) -> None:
        self.layer, self.journal, self.publish = layer, journal, publish
        self.links = dict(robots)
        self.broker = ResourceBroker(self._preempt, self._resume_preempted)
        self.robot_spec = SupervisorSpec(intensity=max_robot_restarts, period=restart_period,
                                         on_exceeded=OnExceeded.QUARANTINE,
                                         probation=probation)
        self.robot_watchdog = robot_watchdog
        self._preempted_timeout = preempted_timeout
        self.robots: pykka.ActorRef[ActorSupervisor] | None = None
        self.actions = OpenActions()
        self._lock = self.actions.lock
        self._held_goals = HeldGoals()
        self._refs: dict[str, pykka.ActorRef[Any]] = {}
        self.availability = RobotAvailability(self.links, journal, self.broker, publish,
                                              self.actions, self)
        self.requesters = Requesters(journal, publish, self.actions, self,
                                     Orphans(adopt_grace, adopt_grace_suspended, clock),
                                     self.announce)
        self.observers = ObserverReports(layer, journal, publish, self.actions, self,
                                         ProgressFeed(progress_every, clock),
                                         self.announce,
                                         lambda: self.robots)
        self.rejections = RejectionLog(log, "action request")
        profiles = profiles or {}
        self.bid_board = BidBoard()  # what robot actors publish for bids
        self.allocator = Allocator(  # tasks addressed to a role (mrss/actors/rcl/allocation)
            {r: profiles.get(r) or RobotProfile(r) for r in self.links},
            board=self.bid_board, where=lambda r: bid_link_state(self.links[r]),
            unavailable=lambda: {**self.availability.teleoperated(),
                                 **self.stand_downs.not_bidding(),
                                 **self.availability.unavailable()},
            award=self.award, publish=publish, ranking=ranking, book=TaskBook(journal),
            reassigned=lambda request, lost, to: self.reallocation.reassigned(request, lost, to),
            decision_lock=self._lock)  # a round and its award: one step of the core
        self.reallocation = Reallocation(self.allocator, journal, self.actions, self, publish)
        self.availability.on_change = self.allocator.kick
        for link in self.links.values():  # a robot's status (teleop) changed: a round soon
            add = getattr(link, "add_telemetry_callback", None)
            if callable(add):
                add(self._status_changed)
        self.stand_downs = StandDowns(  # the operator's stand-downs by area
            self.links, {r: p.capabilities for r, p in profiles.items()},
            lambda r: bid_link_state(self.links[r])[0], journal, self.actions, self, publish)
        self.stand_downs.on_change = self.allocator.kick
        self.availability.on_teleop = self.bid_board.teleop

    def _status_changed(self, record: Mapping[str, Any]) -> None:
        """A robot's telemetry record: a `status` (sent when it changes, e.g. its
        teleop) may make it fit for a waiting task."""
        if record.get("type") == "status":
            self.allocator.kick()

    # -- lifecycle of the core ----------------------------------------------------------
    def start(self, *, new_run: bool = False) -> None:
        """Start the robot supervisor (one actor per robot); they resume the journal's
        open actions, and what cannot be resumed fails explicitly here.

        `new_run`: the whole system (re)started, not just this RCL, so nobody waits for
        the actions left open: they are failed, and old incarnation numbers forgotten.
        """
        self.availability.stopping = False
        self.requesters.reset({} if new_run else self.journal.incarnations())
        if new_run:
            self.journal.drop_controls()  # nobody waits for what they would change
        tasks = self.reallocation.recover(new_run)  # no robot's: the allocator's
        for entry in self.journal.open_actions():
            if entry.action.uuid in tasks:
                continue
            if new_run:
                self.end_unrouted(entry.action, lc.End(
                    ActionState.FAILED, lc.EndCause.RCL_RESTARTED,
                    "left over from a previous run of MRSS"))
            elif entry.action.robot not in self.links:
                self.end_unrouted(entry.action, lc.End(
                    ActionState.FAILED, lc.EndCause.RCL_RESTARTED,
                    f"robot {entry.action.robot!r} is not configured after an RCL restart"))
        decommissioned = self.availability.restore_decommissioned()
        self.stand_downs.restore()
        children = [actor_child(robot, self._robot_factory(robot), watchdog=self.robot_watchdog,
                                shutdown=self.layer.interrupt_timeout + 2.0)
                    for robot in self.links]
        self.robots = ActorSupervisor.start(
            self.robot_spec, children, name="robots", publish=self.availability.publish_sup,
            on_give_up=lambda why: log.error("robot supervisor gave up: %s", why))
        # answered after the supervisor's start hook, which sets every robot actor up
        self.robots.proxy().which_children().get(timeout=30.0)
        for robot, link in self.links.items():  # failsafe hook: no live actor, no heartbeat
            watch = getattr(link, "watch_controller", None)
            if callable(watch):
                watch(functools.partial(self.controls, robot))
        for robot in sorted(decommissioned):  # what it still held (a kill came between)
            self.availability.decommission(robot, True)
        self.announce()  # so the reasoner and the dashboard know each robot now
        # awards recorded before a restart, not yet started; a robot whose link has not
        # reported up since the start gets its award when it does
        self.availability.on_settled = lambda _robot: self.reallocation.carry_out()
        self.reallocation.carry_out()
        self.allocator.start()

    def controls(self, robot: str) -> bool:
        """Whether a live robot actor controls `robot` (its link heartbeats the robot only
        then, so a robot whose actor is gone or quarantined takes its failsafe). Called by
        link threads every second: no lock, a heartbeat never waits for a journal write."""
        ref = self._refs.get(robot)
        return ref is not None and ref.is_alive()

    def stop(self) -> None:
        """Stop every robot actor (and its skills); open actions stay in the journal, for
        the next start to resume: the links that close after this (RclService
        disconnects them) report "link closed", which fails nothing."""
        self.availability.stopping = True
        self.allocator.stop()
        robots, self.robots = self.robots, None
        if robots is None:
            return
        try:
            robots.stop(block=True, timeout=len(self.links) * (self.layer.interrupt_timeout
                                                               + 3.0))
        except pykka.Timeout:
            log.error("robot supervisor did not stop in time")
        with self._lock:
            self._refs.clear()

    @property
    def preempted_timeout(self) -> float:
        """Seconds a pre-empted action may wait before it fails (0: for ever)."""
        return self._preempted_timeout

    def _robot_factory(self, robot: str) -> Callable[[ActorContext], pykka.ActorRef[Any]]:
        def start(ctx: ActorContext) -> pykka.ActorRef[Any]:
            ref: pykka.ActorRef[Any] = RobotActor.start(
                ctx, robot, self.links[robot], self.layer, self.broker, self)
            return ref
        return start

    # -- RobotHost: what robot actors call -------------------------------------------------
    def emit(self, action: Action, suspended_by: str) -> None:
        self._emit(action, suspended_by)

    def save_progress(self, uuid: str, progress: dict[str, Any]) -> None:
        self.journal.save_progress(uuid, progress)
        if self.observers.progress.enabled:
            self.observers.progress.record(uuid, progress)
            self.observers.publish_progress()

    def register(self, robot: str, ref: pykka.ActorRef[Any]) -> None:
        with self._lock:
            self._refs[robot] = ref

    def restore(self, robot: str, first: bool) -> tuple[list[JournalEntry], bool]:
        """A robot actor (re)starts: its open actions, minus those the project won't resume."""
        entries: list[JournalEntry] = []
        for entry in self.journal.open_actions():
            action = entry.action
            if action.robot != robot:
                continue
            if first and not self.layer.resume_after_restart(action.copy()):
                self.end_unrouted(action, lc.End(
                    ActionState.FAILED, lc.EndCause.RCL_RESTARTED, "RCL restarted; the project "
                    f"does not resume {action.name!r} actions", FailureCause.TRANSIENT))
                continue
            self.broker.forget_action(action.uuid)  # holds of a dead incarnation
            self.actions.put(action, entry.requester)
            log.info("restoring action %s (%s) on %s", action.uuid, action.state.value, robot)
            entries.append(entry)
        return entries, robot in self.journal.teleop_robots()

    def pending_controls(self, robot: str) -> list[Control]:
        """The controls for `robot` a dead incarnation of its actor may not have applied."""
        pending = []
        for seq, uuid, text in self.journal.pending_controls(robot):
            try:
                pending.append(Control(uuid, controls.decode(text), seq))
            except DecodeError as exc:
                log.error("robot %s: pending control %d dropped: %s", robot, seq, exc.reason)
                self.journal.claim_control(seq)
        return pending

    def claim_control(self, seq: int) -> None:
        self.journal.claim_control(seq)

    def publish_sup(self, event: Message) -> object:
        """A skill's sup.* event (mrss.actors.rcl.skill_actor) goes out as it is."""
        return self.publish(event)

    @property
    def plans(self) -> PlanBoard:
        return self.observers.plans

    def compact_journal(self, keep_seconds: float, keep_last: int) -> int:
        """Drop old terminal actions from the journal (ActionJournal.compact); how many."""
        dropped = self.journal.compact(keep_seconds, keep_last)
        if dropped:
            log.info("journal compacted: %d ended actions older than %.0fs dropped "
                     "(the newest %d kept)", dropped, keep_seconds, keep_last)
        return dropped

    # -- requests -------------------------------------------------------------------------
    def submit_fields(self, fields: Mapping[str, Any]) -> None:
        """Accept a raw action.request body; a malformed one is rejected with its reason."""
        try:
            request = build(ActionRequest, dict(fields))
        except DecodeError as exc:
            uuid = fields.get("uuid")
            if isinstance(uuid, str) and uuid:
                self._reject(uuid, fields, exc.reason)
            else:
                self.rejections.reject("-", "without a uuid", exc.reason)
            return
        self.submit(request)

    def submit(self, request: ActionRequest, requester: Requester | None = None) -> None:
        """Accept an action request once per uuid; refine and run it on its robot.

        `requester` (the sender's component name and incarnation, from the envelope)
        lets the RCL cancel a dead incarnation's orphans (its late requests never get
        here: the bus drops them, mrss/bus/incarnations.py).
        """
        requester = requester or NOBODY
        if requester.src:
            self.requesters.saw_incarnation(requester.src, requester.inc)
        with self._lock:
            if self.requesters.repeat(request.uuid, requester):
                return
            self._accept(request, requester)

    def _accept(self, request: ActionRequest, requester: Requester,
                progress: Mapping[str, JsonValue] | None = None) -> None:
        """A new request (or a task's award): refine it and run it on its robot."""
        with self._lock:
            try:
                request.validate()
                if request.role and not request.robot:  # addressed to a role: bids decide
                    self.allocator.submit(request, requester)
                    return
                action = self.layer.action_cb(request)
                if action.uuid != request.uuid:
                    raise ActionError("action_cb changed the uuid", uuid=request.uuid)
                check_json(action.args, "action arguments")
                if action.robot not in self.links:
                    raise ActionError(f"unknown robot {action.robot!r} (known: "
                                      f"{', '.join(sorted(self.links)) or 'none'})")
                refusal = self.availability.refusal(action.robot)
                if refusal is not None:
                    self._reject(request.uuid, _fields(request),
                                 f"robot {action.robot} unavailable: {refusal[0]}", requester,
                                 refusal[1])
                    return
            except Exception as exc:
                reason = exc.reason if isinstance(exc, ActionError | DecodeError) else repr(exc)
                known = self.journal.get(request.uuid) if progress is not None else None
                if known is not None and not known.action.terminal:  # a task given back
                    self.end_unrouted(known.action, lc.End(ActionState.FAILED,
                                                           lc.EndCause.REJECTED,
                                                           f"rejected: {reason}"))
                else:
                    self._reject(request.uuid, _fields(request), reason, requester)
                return
            action.state, action.reason = ActionState.PENDING, ""
            if progress:
                action.progress = dict(progress)  # from the robot that lost the task
            held = self._held_goals.cause_for(action.goal, requester.src)
            stood_down = self.stand_downs.cause_for(action.robot) if held is None else None
            start = StartAction(action, held) if stood_down is None else \
                StartAction(action, stood_down.by, stood_down.reason)
            # Journaled first, then the robot actor is told (it starts the skills while
            # PENDING goes out), all under the lock: a later control comes after the
            # StartAction, and the actor's RUNNING waits for the lock, so after PENDING.
            self._emit(action.copy(), "", requester, new=True,  # `repeat` read the journal
                       before_publish=lambda: self._start(action, start))

    def _start(self, action: Action, start: StartAction) -> None:
        """Tell the robot actor; the action is its work for bids from now on."""
        self.bid_board.started(action.robot, Work(action.uuid, action.priority, 0.0))
        self.tell(action.robot, start)

    def award(self, request: ActionRequest, requester: Requester, robot: str,
              progress: dict[str, JsonValue]) -> None:
        """A role-addressed task was awarded (the book has it): it goes on as a request
        addressed to `robot` (its first argument the robot, as `name(Robot, Goal, ...)`
        has it), from `progress`. A robot unavailable since its bid gives it back."""
        args = [robot, *request.args[1:]] if request.args else [robot]
        with self._lock:
            known = self.journal.get(request.uuid)
            if self.allocator.book.holder(request.uuid) != robot or known is None \
                    or known.action.terminal:  # ended (cancelled) while it was decided
                self.rejections.reject(robot, "award for a task no longer open",
                                       f"{request.uuid}: award to {robot} dropped (task "
                                       f"{known.action.state.value if known else 'unknown'})")
                return
            requester = known.requester  # a newer incarnation may have adopted it
            if self.refused(robot):
                if self.allocator.book.lost(request.uuid, robot) is not None:
                    self.allocator.reopen(request, requester, robot, progress)
                return
            self._accept(dataclasses.replace(request, robot=robot, args=args, role={}),
                         requester, progress)

    def announce(self) -> None:
        """Every robot's state and every active stand-down (level-triggered)."""
        self.availability.announce_robots()
        self.stand_downs.announce()

    def check_batteries(self) -> None:
        """Tasks addressed to a role held by a robot whose battery is critical go to
        others (Reallocation.battery_check; the RCL calls it every heartbeat tick)."""
        self.reallocation.battery_check(
            lambda r: bid_link_state(self.links[r])[1] if r in self.links else None)

    def awaiting(self, robot: str) -> bool:
        """Whether `robot`'s link has not reported up since the start (and may yet)."""
        return self.availability.awaiting(robot)

    def refused(self, robot: str) -> bool:
        """Whether a new action for `robot` would be refused now (one not configured,
        e.g. an award journaled before a restart that removed it, is)."""
        return robot not in self.links or self.availability.refusal(robot) is not None

    def _reject(self, uuid: str, fields: Mapping[str, Any], reason: str,
                requester: Requester = NOBODY,
                cause: lc.EndCause = lc.EndCause.REJECTED) -> None:
        self.rejections.reject(requester.src or "-", reason_kind(reason), f"{uuid}: {reason}")
        with self._lock:
            if self.journal.get(uuid) is not None:
                return
            action = Action(uuid=uuid, name=str(fields.get("name", "")))
            for key in ("robot", "goal"):
                if isinstance(fields.get(key), str):
                    setattr(action, key, fields[key])
            end = lc.end_unrouted(action.state, lc.End(ActionState.FAILED, cause,
                                                       f"rejected: {reason}"))
            action.transition(end.state, end.reason, end.cause)
            self._emit(action, "", requester)

    # -- goal management, teleop, availability -------------------------------------------
    def control(self, control: ActionControl, src: str = "") -> list[str]:
        """Apply cancel/suspend/resume/succeed/fail to an action, a goal or a robot.

        `src` is the sender: a control from an action's own requester is the agent's,
        any other (the dashboard, `mrss send`, a test) the operator's."""
        control.validate()
        with self._lock:
            if control.target_kind is ControlTarget.GOAL:
                self._held_goals.control(control.command, control.target, src)
            chosen = self.actions.matching(
                lambda u, e: (control.target_kind is ControlTarget.ACTION and u == control.target)
                or (control.target_kind is ControlTarget.GOAL and e.goal == control.target)
                or (control.target_kind is ControlTarget.ROBOT and e.robot == control.target))
            targets = list(chosen)
            robots = {u: e.robot for u, e in chosen.items()}
            agent = {u for u, e in chosen.items() if src and e.requester.src == src}
            targets += self._control_waiting(control, src)
        if not targets and control.target_kind is ControlTarget.GOAL \
                and control.command is ControlCommand.SUSPEND:
            log.info("suspend goal %r: no action yet; held for its later ones", control.target)
        elif not targets:
            log.warning("%s %s %r: no active action", control.command, control.target_kind,
                        control.target)
        for uuid in targets:
            if uuid in robots:
                self.tell(robots[uuid], Control(uuid, _event_of(control.command,
                                                                uuid in agent)))
        return targets

    def _control_waiting(self, control: ActionControl, src: str) -> list[str]:
        """Under the lock: a cancel, succeed or fail of a task that waits for a robot ends
        it here (no robot runs it; the allocator bids for it no more); a suspend or
        resume leaves it waiting. The uuids ended."""
        if control.command not in _END_OF or control.target_kind is ControlTarget.ROBOT:
            return []
        ended = []
        for uuid, holder in self.allocator.book.holders().items():
            if holder:
                continue
            entry = self.journal.get(uuid)
            if entry is None or entry.action.terminal or entry.action.robot or not (
                    uuid == control.target if control.target_kind is ControlTarget.ACTION
                    else entry.action.goal == control.target):
                continue
            self.allocator.withdraw(uuid)
            by_agent = bool(src) and entry.requester.src == src
            self.end_unrouted(entry.action, lc.End(
                _END_OF[control.command],
                lc.EndCause.AGENT if by_agent else lc.EndCause.OPERATOR,
                f"{_END_OF[control.command].value} by the "
                f"{'agent' if by_agent else 'operator'} while it waited for a robot"))
            ended.append(uuid)
        return ended

    # -- plumbing ---------------------------------------------------------------------------
    def _emit(self, action: Action, suspended_by: str,
              requester: Requester | None = None, *, new: bool = False,
              before_publish: Callable[[], None] | None = None) -> None:
        """Journal (committed) first, then publish: a status is never out before it's safe.

        `new`: the caller found no journal entry for the uuid under the lock (an accepted
        request), so it is not looked up again (one read less on the action path).
        `before_publish` runs after the commit, under the lock, before the publication."""
        if action.terminal and self.reallocation.ending(action):
            return  # its robot was lost: the task went back to allocation instead
        known = self.actions.get(action.uuid)
        if known is None and not new:
            done = self.journal.get(action.uuid)
            if done is not None and done.action.terminal:
                log.warning("action %s is already %s; %s dropped", action.uuid,
                            done.action.state.value, action.state.value)
                return
        if requester is None:
            requester = known.requester if known else NOBODY
        self.journal.record(action, suspended_by, requester)
        if action.terminal:
            self.reallocation.ended(action)
        with self._lock:  # with the publication: see publish_progress
            if action.terminal:
                self.actions.drop(action.uuid)
                self.observers.progress.forget(action.uuid)
                self.bid_board.ended(action.uuid)
                self.allocator.kick()  # its robot may be free for a waiting task
            else:
                self.actions.put(action, requester)
            if before_publish is not None:
                before_publish()
            self.publish_status(action)

    # -- Routes: what the collaborators ask of the core -----------------------------------
    def publish_status(self, action: Action, repeat: bool = False) -> None:
        """Publish an action's status (journaled already); a failure is logged."""
        status = ActionStatus(uuid=action.uuid, state=action.state, reason=action.reason,
                              progress=dict(action.progress), robot=action.robot,
                              cause=FailureCause(action.cause), repeat=repeat, name=action.name,
                              goal=action.goal, critical=action.critical,
                              critical_bound=action.critical_bound,
                              deferring=action.deferring,
                              progress_bound=action.progress_bound)
        try:
            self.publish(status)
        except Exception as exc:  # the journal has it; a reconnecting sender re-asks
            log.error("publishing status of %s failed: %r", action.uuid, exc)

    def end_unrouted(self, action: Action, end: lc.End) -> None:
        """End an action no robot actor runs (lifecycle.end_unrouted)."""
        publish = lc.end_unrouted(action.state, end)
        log.warning("ending action %s (%s): %s", action.uuid, publish.state.value,
                    publish.reason)
        action.transition(publish.state, publish.reason, publish.cause)
        try:
            self.layer.on_action_end(action.copy())
        except Exception as exc:
            log.error("on_action_end(%s) raised %r", action.uuid, exc)
        self._emit(action, "")

    def tell(self, robot: str, message: object) -> None:
        """Send to the robot's current incarnation. Nothing is lost if it is down: a
        StartAction is journaled first (the next incarnation restores the action), a
        Control is journaled pending here (the next incarnation applies it)."""
        if isinstance(message, Control) and not message.seq:
            try:
                seq = self.journal.add_control(robot, message.uuid,
                                               controls.encode(message.event))
                message = dataclasses.replace(message, seq=seq)
            except Exception as exc:  # the live actor may still get it
                log.error("journaling a control for %s failed: %r", message.uuid, exc)
        with self._lock:
            ref = self._refs.get(robot)
        try:
            if ref is None:
                raise pykka.ActorDeadError(robot)
            ref.tell(message)
        except pykka.ActorDeadError:
            log.warning("robot actor %s is down; %r waits for its next incarnation",
                        robot, message)

    def _preempt(self, uuid: str, resource: str) -> None:
        self.control_one(uuid, lc.Suspend(lc.SuspendCause.PREEMPTED, f"pre-empted: {resource} "
                                           "is needed by a higher-priority action"))

    def _resume_preempted(self, uuid: str, resource: str) -> None:
        self.control_one(uuid, lc.Resume(lc.SuspendCause.PREEMPTED))

    def control_one(self, uuid: str, event: lc.Suspend | lc.Resume | lc.End) -> None:
        """Send a lifecycle event to the robot actor running `uuid` (if it is open)."""
        entry = self.actions.get(uuid)
        if entry is not None:
            self.tell(entry.robot, Control(uuid, event))


_END_OF = {"cancel": ActionState.CANCELLED, "succeed": ActionState.SUCCEEDED,
           "fail": ActionState.FAILED}


def _event_of(command: str, by_agent: bool) -> lc.Suspend | lc.Resume | lc.End:
    """The lifecycle event of a goal-management command (ActionControl validated it)."""
    if command in _END_OF:
        return lc.End(_END_OF[command], lc.EndCause.AGENT if by_agent else lc.EndCause.OPERATOR)
    by = lc.SuspendCause.AGENT if by_agent else lc.SuspendCause.OPERATOR
    return lc.Suspend(by) if command == "suspend" else lc.Resume(by)


def _fields(request: ActionRequest) -> dict[str, Any]:
    return {"name": request.name, "robot": request.robot, "goal": request.goal}
