"""One supervised pykka actor per robot: its link, teleop flag, its actions, their skills.

One idea in one module (~500 lines): the actor that performs the lifecycle's effects for
one robot, with the stop deadline its skills' critical sections hold off; the decisions
are lifecycle.py's, the skills skill_actor.py's.

The robot actor carries out the action lifecycle (mrss.actors.rcl.lifecycle): it feeds
`lifecycle.step` what happens to an action (accepted, a skill ended, a control, a teleop,
a stop completed or timed out) and performs the effects it returns: refine the action
and start a SkillActor per skill, interrupt or abandon them, ask the project's
`check_action_status`, journal and publish a status (through `emit`), release resources.
Which transition happens, and why, is decided there, never here. Project code that
raises fails the action, never this actor. The actor runs under the RCL's robot
supervisor (mrss.supervision): if it crashes anyway, its next incarnation's `setup` takes
its open actions back from the journal.
"""

from __future__ import annotations

import logging
import threading
import time
from collections.abc import Callable, Mapping
from dataclasses import dataclass, field
from typing import Any, Protocol

import pykka

from mrss.actors.rcl import lifecycle as lc
from mrss.actors.rcl.action import Action
from mrss.actors.rcl.allocation.bids import Work, fraction_done
from mrss.actors.rcl.allocation.board import BidBoard, BidState
from mrss.actors.rcl.failure_causes import failure_cause
from mrss.actors.rcl.going_home import GoHome, HomeErrand
from mrss.actors.rcl.journal import JournalEntry
from mrss.actors.rcl.layer import RobotCommLayer
from mrss.actors.rcl.resources import ResourceBroker
from mrss.actors.rcl.skill import CriticalSection, Skill, SkillOutcome, progress_bound_of
from mrss.actors.rcl.skill_actor import (
    CriticalChanged,
    ProgressRecorded,
    SkillActor,
    SkillReport,
    SkillRunner,
    StopSkill,
)
from mrss.messages import ActionState, JsonValue, Message
from mrss.messages.plans import PLAN_RECORD, PlanBoard, clear_record
from mrss.supervision import ActorContext, Escalation, SupervisedActor

log = logging.getLogger("mrss.rcl.robot")


class RobotHost(Protocol):
    """What a robot actor needs from the RCL core."""

    def emit(self, action: Action, suspended_by: str) -> None:
        """Journal the action's state (committed), then publish it."""

    def save_progress(self, uuid: str, progress: dict[str, Any]) -> None:
        """Journal progress (no status goes out)."""

    def register(self, robot: str, ref: pykka.ActorRef[Any]) -> None:
        """The robot's current actor incarnation, for routing."""

    def restore(self, robot: str, first: bool) -> tuple[list[JournalEntry], bool]:
        """The robot's open actions to take back (journal) and its teleop flag."""

    def pending_controls(self, robot: str) -> list[Control]:
        """The controls journaled for `robot` and not yet applied, oldest first."""

    def claim_control(self, seq: int) -> None:
        """A control was applied: it is no longer pending."""

    @property
    def preempted_timeout(self) -> float:
        """Seconds a pre-empted action may wait before it fails (0: for ever)."""

    def publish_sup(self, event: Message) -> object:
        """Publish a supervision event (a skill's restart or escalation)."""

    @property
    def plans(self) -> PlanBoard:
        """The latest plan of each open action (sent again with the RCL's snapshot)."""

    @property
    def bid_board(self) -> BidBoard:
        """Where the robot's state for bids goes (read by the allocator, no round trip)."""


@dataclass(frozen=True)
class StartAction:
    """Take on a new action (journaled PENDING); `held`: its goal is suspended already."""

    action: Action
    held: lc.SuspendCause | None = None
    why: str = ""  # why it is held, when not its goal (a stand-down by area)


@dataclass(frozen=True)
class Control:
    """A lifecycle event for one action (a suspend, resume or end by command); `seq`
    is its pending entry in the journal (mrss.actors.rcl.controls), 0 if not journaled."""

    uuid: str
    event: lc.Suspend | lc.Resume | lc.End
    seq: int = 0


@dataclass(frozen=True)
class SetTeleop:
    on: bool


@dataclass(frozen=True)
class _StopDeadline:
    uuid: str
    run: int
    gen: int = 0  # which arming of the deadline (a critical section holds it off)


@dataclass(frozen=True)
class _PreemptedTooLong:
    uuid: str
    episode: int  # which pre-emption of the action the timer was set for


@dataclass
class _Tracked:
    action: Action
    life: lc.Lifecycle
    run: int = 0
    refs: list[pykka.ActorRef[SkillActor] | None] = field(default_factory=list)
    outcomes: list[SkillOutcome | None] = field(default_factory=list)
    reasons: list[str] = field(default_factory=list)
    causes: list[str] = field(default_factory=list)
    timer: threading.Timer | None = None
    preempted_timer: threading.Timer | None = None
    preemptions: int = 0
    sections: dict[int, CriticalSection] = field(default_factory=dict)  # skill -> open
    deadlines: int = 0


class RobotActor(SupervisedActor):
    """Runs the actions of one robot (on the shared threads of mrss.supervision.pooled
    while it has mail: a fleet's robot actors hold no thread each)."""

    pooled = True

    def __init__(self, ctx: ActorContext, robot: str, link: Any, layer: RobotCommLayer,
                 broker: ResourceBroker, host: RobotHost) -> None:
        super().__init__(ctx)
        self.robot, self.link, self.layer, self.broker = robot, link, layer, broker
        self.host = host
        self.emit, self.save_progress = host.emit, host.save_progress
        self.teleop = False
        self.actions: dict[str, _Tracked] = {}
        self._replayed: set[int] = set()  # pending controls applied by `setup`
        self._published: BidState | None = None  # on the bid board
        self.home = HomeErrand(robot, link)  # a stand-down's "go home", once stopped

    def _skill_data_fn(self, uuid: str) -> Callable[[Mapping[str, JsonValue]], bool]:
        """A skill's robot data goes out as the robot's (on the skill's thread); a plan
        is remembered, to be cleared when its action ends."""
        def publish(record: Mapping[str, JsonValue]) -> bool:
            if record.get("type") == PLAN_RECORD:
                self.host.plans.sent(self.robot, uuid, record)
            return self.layer.publish_data(self.robot, record)
        return publish

    def setup(self) -> None:
        """Start hook: register, then take this robot's open actions back from the journal.

        Registering first means a request journaled after the journal read below is
        told to this incarnation; one journaled before is restored here (and a late
        StartAction for it is ignored). The same holds for controls: those still pending
        are applied here, after the actions are back, and again never from the mailbox.
        """
        first = self.ctx.incarnation == 1
        self.host.register(self.robot, self.actor_ref)
        entries, self.teleop = self.host.restore(self.robot, first)
        why = "an RCL restart" if first else f"a restart of robot actor {self.robot}"
        for entry in entries:
            if entry.action.uuid in self.actions:
                continue
            by = lc.SuspendCause.parse(entry.suspended_by)
            t = _Tracked(entry.action.copy(), lc.Lifecycle.of(entry.action.state, by))
            self.actions[t.action.uuid] = t
            self._feed(t, lc.Restore(why, by, self.teleop))
        for control in self.host.pending_controls(self.robot):
            log.info("robot %s: applying pending control %d (%s for %s)", self.robot,
                     control.seq, control.event.kind.value, control.uuid)
            self._control(control)
            self._replayed.add(control.seq)
        self._publish_bid_state()

    # -- dispatch ---------------------------------------------------------------------
    def on_receive(self, message: Any) -> Any:
        try:
            return self._dispatch(message)
        finally:
            self._publish_bid_state()
            self.home.check(any(r is not None for t in self.actions.values() for r in t.refs))

    def _dispatch(self, message: Any) -> Any:
        if isinstance(message, SkillReport):
            self._skill_ended(message)
        elif isinstance(message, ProgressRecorded):
            self._progress(message)
        elif isinstance(message, CriticalChanged):
            self._critical(message)
        elif isinstance(message, StartAction):
            self._start(message)
        elif isinstance(message, Control):
            self._control(message)
        elif isinstance(message, SetTeleop):
            self._set_teleop(message.on)
        elif isinstance(message, GoHome):
            self.home.ask(message)
        elif isinstance(message, _StopDeadline):
            self._deadline(message)
        elif isinstance(message, _PreemptedTooLong):
            self._preempted_too_long(message)
        else:
            log.warning("robot %s: unexpected message %r", self.robot, message)
        return None

    def _work(self) -> tuple[Work, ...]:
        return tuple(Work(u, t.action.priority, fraction_done(t.action.progress))
                     for u, t in self.actions.items() if not t.action.terminal)

    def _publish_bid_state(self) -> None:
        """What the allocator computes this robot's bids from (mrss.actors.rcl.allocation
        .board), replaced when it changed."""
        state = BidState(self.teleop, self._work())
        if state != self._published:
            self._published = state
            self.host.bid_board.publish(self.robot, state)

    def teardown(self) -> None:
        """Stop or crash: stop every skill, change no state (the journal has them)."""
        if self._published is not None:
            self.host.bid_board.withdraw(self.robot, self._published)
        refs = [r for t in self.actions.values() for r in t.refs if r is not None]
        for t in self.actions.values():
            for timer in (t.timer, t.preempted_timer):
                if timer:
                    timer.cancel()
        for ref in refs:
            try:
                ref.tell(StopSkill(urgent=True))
            except pykka.ActorDeadError:
                pass  # that skill has just ended
        # A skill actor stops itself once its worker has returned (_WorkerDone): wait for
        # that, not for the actor alone, so that no worker of this incarnation is still
        # between two link commands when the next one resumes the action from the journal.
        deadline = time.monotonic() + self.layer.interrupt_timeout
        busy = [ref for ref in refs
                if not ref.actor_stopped.wait(max(0.0, deadline - time.monotonic()))]
        if busy:
            log.error("robot %s: skills still busy at shutdown; abandoned", self.robot)
            for ref in busy:
                ref.stop(block=False)

    # -- events in ------------------------------------------------------------------------
    def _start(self, msg: StartAction) -> None:
        if msg.action.uuid in self.actions:
            return  # restored from the journal already
        t = _Tracked(msg.action.copy(), lc.Lifecycle.of(msg.action.state))
        self.actions[t.action.uuid] = t
        self._feed(t, lc.Accept(self.teleop, msg.held, msg.why))

    def _progress(self, msg: ProgressRecorded) -> None:
        t = self.actions.get(msg.uuid)
        if t is None or msg.run != t.run:
            return
        t.action.progress.update(msg.values)
        for key in msg.forget:
            t.action.progress.pop(key, None)
        self.save_progress(msg.uuid, dict(t.action.progress))

    def _skill_ended(self, msg: SkillReport) -> None:
        t = self.actions.get(msg.uuid)
        if t is None or msg.run != t.run or t.refs[msg.index] is None:
            return  # a skill of an earlier run, or one already abandoned
        t.refs[msg.index] = None
        t.outcomes[msg.index], t.reasons[msg.index] = msg.outcome, msg.reason
        t.causes[msg.index] = msg.cause
        self._feed(t, lc.SkillEnded(all_ended=all(r is None for r in t.refs)))
        if msg.escalated:  # its action has failed above; now this actor fails in turn
            raise Escalation(f"skill {msg.index} of action {msg.uuid} escalated: {msg.reason}")

    def _critical(self, msg: CriticalChanged) -> None:
        """A skill entered, left or outlasted a critical section: hold the stop deadline
        while one is open (a deferred stop), arm it when none is; publish the state."""
        t = self.actions.get(msg.uuid)
        if t is None or msg.run != t.run:
            return
        before = t.sections.get(msg.index)
        if msg.section is None or msg.overrun:
            t.sections.pop(msg.index, None)
        else:
            t.sections[msg.index] = msg.section
        stop = t.life.stop if t.life.phase is lc.Phase.STOPPING else None
        if stop is not None and not stop.urgent:
            if t.sections and t.timer is not None:  # it opened before the stop came
                t.timer.cancel()
                t.timer = None
            elif not t.sections and t.timer is None:
                self._arm_deadline(t)  # the deferred stop goes ahead now
        section = msg.section or before
        name = section.name if section else ""
        bound = section.bound if section else 0.0
        reason = (f"critical section {name!r} held past its bound {bound:g}s" if msg.overrun
                  else f"critical section {name!r} ended" if msg.section is None
                  else f"in critical section {name!r} (at most {bound:g}s)")
        self._show_sections(t, reason)

    def _show_sections(self, t: _Tracked, reason: str) -> None:
        """Publish the action's critical section state (RUNNING, re-announced)."""
        if t.action.state is not ActionState.RUNNING:
            return
        open_ = next(iter(t.sections.values()), None)
        stop = t.life.stop if t.life.phase is lc.Phase.STOPPING else None
        t.action.critical = open_.name if open_ else ""
        t.action.critical_bound = open_.bound if open_ else 0.0
        t.action.deferring = bool(open_ and stop is not None and not stop.urgent)
        t.action.reason = reason
        self.emit(t.action.copy(), "")

    def _preempted_too_long(self, msg: _PreemptedTooLong) -> None:
        t = self.actions.get(msg.uuid)
        if t is None or t.preemptions != msg.episode \
                or t.life.suspended_by is not lc.SuspendCause.PREEMPTED:
            return
        limit = self.host.preempted_timeout
        log.warning("robot %s: action %s pre-empted for more than %gs: failed", self.robot,
                    msg.uuid, limit)
        self._feed(t, lc.End(ActionState.FAILED, lc.EndCause.PREEMPTED,
                             f"pre-empted for more than {limit:g}s (preempted_timeout)"))

    def _watch_preemption(self, t: _Tracked) -> None:
        """The project's policy `preempted_timeout`: a timer while the action is
        suspended by pre-emption alone."""
        preempted = t.life.suspended_by is lc.SuspendCause.PREEMPTED \
            and t.action.uuid in self.actions
        if preempted and t.preempted_timer is None and self.host.preempted_timeout > 0:
            t.preemptions += 1
            t.preempted_timer = threading.Timer(self.host.preempted_timeout, self._tell, (
                _PreemptedTooLong(t.action.uuid, t.preemptions),))
            t.preempted_timer.daemon = True
            t.preempted_timer.start()
        elif not preempted and t.preempted_timer is not None:
            t.preempted_timer.cancel()
            t.preempted_timer = None

    def _tell(self, message: object) -> None:
        try:
            self.actor_ref.tell(message)
        except pykka.ActorDeadError:
            pass

    def _deadline(self, msg: _StopDeadline) -> None:
        t = self.actions.get(msg.uuid)
        if t is None or t.run != msg.run or t.life.phase is not lc.Phase.STOPPING \
                or msg.gen != t.deadlines:
            return
        self._feed(t, lc.DeadlinePassed())

    def _control(self, msg: Control) -> None:
        """Apply a control once (mrss.actors.rcl.controls), then mark it applied."""
        if msg.seq in self._replayed:
            self._replayed.discard(msg.seq)
            return  # applied by setup from the journal already
        t = self.actions.get(msg.uuid)
        if t is None:
            log.info("robot %s: %s for %s ignored: not active", self.robot,
                     msg.event.kind.value, msg.uuid)
        else:
            event = msg.event
            if isinstance(event, lc.Resume):
                event = lc.Resume(event.by, self.teleop)
            self._feed(t, event)
        if msg.seq:
            self.host.claim_control(msg.seq)

    def _set_teleop(self, on: bool) -> None:
        if on == self.teleop:
            return
        self.teleop = on
        for t in list(self.actions.values()):
            if on:
                self._feed(t, lc.Suspend(lc.SuspendCause.TELEOP, "robot in teleop"))
            else:
                self._feed(t, lc.Resume(lc.SuspendCause.TELEOP, teleop=False))

    # -- the lifecycle decides, this carries out --------------------------------------------
    def _feed(self, t: _Tracked, event: lc.Event) -> None:
        """Step the action's lifecycle and perform the effects, in order."""
        try:
            t.life, effects = lc.step(t.life, event)
        except lc.IllegalEvent as exc:
            log.error("robot %s: action %s: %s", self.robot, t.action.uuid, exc.reason)
            return
        for effect in effects:
            if not self._perform(t, effect):
                return  # the effect fed another event, which carried on
        self._watch_preemption(t)

    def _perform(self, t: _Tracked, effect: lc.Effect) -> bool:
        """Carry out one effect; False when it fed a follow-up event instead."""
        if isinstance(effect, lc.Run):
            return self._run(t, effect.reason)
        if isinstance(effect, lc.Interrupt):
            return self._interrupt(t, effect.urgent)
        if isinstance(effect, lc.CheckStatus):
            self._check(t)
            return False
        if isinstance(effect, lc.Abandon):
            self._abandon_skills(t)
        elif isinstance(effect, lc.ReleaseResources):
            self.broker.forget_action(t.action.uuid)
        elif isinstance(effect, lc.Announce):
            t.action.reason = effect.reason
            self.emit(t.action.copy(), effect.suspended_by or "")
        elif isinstance(effect, lc.Publish):
            self._publish(t, effect)
        return True

    def _run(self, t: _Tracked, reason: str) -> bool:
        """Refine the action (again, from its progress) and start its skills."""
        if t.timer:
            t.timer.cancel()
            t.timer = None
        t.run += 1
        snapshot = t.action.copy()
        try:
            skills = self.layer.refine_action(snapshot)
            bad = [s for s in skills if not isinstance(s, Skill)]
            if bad:
                raise TypeError(f"refine_action returned non-skills {bad!r}")
        except Exception as exc:
            why = f"cannot refine {t.action.name}: {exc}"
            log.warning("robot %s: action %s failed: %s", self.robot, t.action.uuid, why)
            self._feed(t, lc.RefineFailed(why, failure_cause(exc)))
            return False
        # The skills start first (the robot moves sooner), RUNNING is journaled and
        # published right after: whatever they report is handled after this method, so
        # the statuses keep their order; a crash in between restores the action anyway.
        t.refs, t.outcomes, t.sections = [], [None] * len(skills), {}
        t.action.critical, t.action.critical_bound, t.action.deferring = "", 0.0, False
        t.reasons, t.causes = [""] * len(skills), [""] * len(skills)
        for index, skill in enumerate(skills):
            runner = SkillRunner(snapshot, t.run, index, self.link, self.broker,
                                 self.actor_ref.tell, self.host.publish_sup,
                                 self._skill_data_fn(snapshot.uuid))
            t.refs.append(SkillActor.start(skill, runner, self.actor_ref.tell))
        t.action.progress_bound = progress_bound_of(skills)  # on the RUNNING status
        if t.action.state is not ActionState.RUNNING:
            t.action.transition(ActionState.RUNNING, reason)
            self.emit(t.action.copy(), "")
        elif reason:  # restored while RUNNING: no transition, but say so
            t.action.reason = reason
            self.emit(t.action.copy(), "")
        if not skills:
            self._check(t)
            return False
        return True

    def _check(self, t: _Tracked) -> None:
        """Ask the project whether the action is over (default: AND of its skills)."""
        all_ended = all(r is None for r in t.refs)
        try:
            verdict = self.layer.check_action_status(t.action.copy(), list(t.outcomes))
        except Exception as exc:
            verdict, why = ActionState.FAILED, f"check_action_status raised {exc!r}"
        else:
            why = next((r for r, o in zip(t.reasons, t.outcomes, strict=True)
                        if o is not None and o is not SkillOutcome.SUCCEEDED), "")
        if not isinstance(verdict, ActionState | None):
            verdict, why = ActionState.FAILED, f"check_action_status returned {verdict!r}"
        cause = next((c for c in t.causes if c), "")
        self._feed(t, lc.Verdict(verdict, why, cause, all_ended))

    def _interrupt(self, t: _Tracked, urgent: bool) -> bool:
        """Interrupt the skills still running; with none, the stop is complete. A stop
        that is not urgent waits for the skills' critical sections (skill_actor.py): its
        deadline is armed when the last one ends."""
        running = [r for r in t.refs if r is not None]
        if not running:
            self._feed(t, lc.Stopped())
            return False
        for ref in running:
            try:
                ref.tell(StopSkill(urgent))
            except pykka.ActorDeadError:
                pass  # ended meanwhile: its SkillReport is on the way
        if urgent or not t.sections:
            self._arm_deadline(t)
        else:
            if t.timer:
                t.timer.cancel()
                t.timer = None
            stop = t.life.stop
            what = stop.target.value if stop is not None else "stop"
            names = ", ".join(repr(s.name) for s in t.sections.values())
            self._show_sections(t, f"{what} deferred until critical section {names} ends")
        if urgent and t.sections:
            self._show_sections(t, "interrupted inside its critical section")
        return True

    def _arm_deadline(self, t: _Tracked) -> None:
        """(Re)start the stop deadline: the skills must end within interrupt_timeout."""
        if t.timer:
            t.timer.cancel()
        t.deadlines += 1
        t.timer = threading.Timer(self.layer.interrupt_timeout, self._tell, (
            _StopDeadline(t.action.uuid, t.run, t.deadlines),))
        t.timer.daemon = True
        t.timer.start()

    def _abandon_skills(self, t: _Tracked) -> None:
        for index, ref in enumerate(t.refs):
            if ref is not None:
                log.error("robot %s: skill %d of action %s ignored its interrupt for %.1fs; "
                          "abandoned", self.robot, index, t.action.uuid,
                          self.layer.interrupt_timeout)
                self.broker.release_token(f"{t.action.uuid}/{t.run}/{index}")
                ref.stop(block=False)
                t.refs[index], t.outcomes[index] = None, SkillOutcome.INTERRUPTED

    def _publish(self, t: _Tracked, effect: lc.Publish) -> None:
        if t.timer:
            t.timer.cancel()
            t.timer = None
        t.action.transition(effect.state, effect.reason, effect.cause)
        t.action.critical, t.action.critical_bound, t.action.deferring = "", 0.0, False
        if effect.state.terminal:
            try:
                self.layer.on_action_end(t.action.copy())
            except Exception as exc:
                log.error("robot %s: on_action_end(%s) raised %r", self.robot,
                          t.action.uuid, exc)
        self.emit(t.action.copy(), effect.suspended_by or "")
        if effect.state.terminal:
            if self.host.plans.ended(t.action.uuid):
                self.layer.publish_data(self.robot, clear_record(t.action.uuid))
            self.broker.forget_action(t.action.uuid)
            del self.actions[t.action.uuid]
