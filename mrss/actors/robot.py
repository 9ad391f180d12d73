"""One supervised pykka actor per robot: its link, teleop flag, its actions, their skills.

The robot actor owns the lifecycle of its actions: it refines them into skills, starts a
SkillActor per skill, decides the action's end with the project's `check_action_status`,
and stops skills for cancel/suspend/succeed/fail. Every transition goes through `emit`
(journal, then publish). Project code that raises fails the action, never this actor.
The actor runs under the RCL's robot supervisor (mrss.supervision): if it crashes anyway,
its next incarnation's `setup` takes its open actions back from the journal.

Suspension causes, strongest first: "control" (goal management), "teleop", and
"resource:<name>" (pre-empted). A resume only lifts its own cause, except a control
resume, which lifts any cause but a teleop still in force.
"""

from __future__ import annotations

import logging
import threading
from dataclasses import dataclass, field
from typing import Any, Protocol

import pykka

from mrss.actors.journal import JournalEntry
from mrss.actors.resources import ResourceBroker
from mrss.actors.skill import (
    Interrupt,
    ProgressRecorded,
    SkillActor,
    SkillEnded,
    SkillRunner,
)
from mrss.api import Action, RobotCommLayer, Skill, SkillOutcome
from mrss.messages import ActionState
from mrss.supervision import ActorContext, SupervisedActor

log = logging.getLogger("mrss.rcl.robot")

BY_CONTROL, BY_TELEOP = "control", "teleop"


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

_END_OF = {"cancel": ActionState.CANCELLED, "succeed": ActionState.SUCCEEDED,
           "fail": ActionState.FAILED}


def _rank(cause: str) -> int:
    return {BY_CONTROL: 3, BY_TELEOP: 2}.get(cause, 1 if cause else 0)


@dataclass(frozen=True)
class StartAction:
    """Take on an action: new (PENDING), or restored from the journal (`restored` says why)."""

    action: Action
    suspended_by: str = ""
    restored: str = ""


@dataclass(frozen=True)
class Control:
    """Goal management for one action: cancel, suspend, resume, succeed, fail."""

    uuid: str
    command: str
    reason: str = ""
    by: str = BY_CONTROL


@dataclass(frozen=True)
class SetTeleop:
    on: bool


@dataclass(frozen=True)
class _StopDeadline:
    uuid: str
    run: int


@dataclass
class _Stopping:
    target: ActionState
    reason: str
    by: str
    resume_after: bool = False
    timer: threading.Timer | None = None


@dataclass
class _Tracked:
    action: Action
    suspended_by: str = ""
    run: int = 0
    refs: list[pykka.ActorRef[SkillActor] | None] = field(default_factory=list)
    outcomes: list[SkillOutcome | None] = field(default_factory=list)
    reasons: list[str] = field(default_factory=list)
    stopping: _Stopping | None = None


class RobotActor(SupervisedActor):
    """Runs the actions of one robot."""

    def __init__(self, ctx: ActorContext, robot: str, link: Any, layer: RobotCommLayer,
                 broker: ResourceBroker, host: RobotHost) -> None:
        super().__init__(ctx)
        self.robot, self.link, self.layer, self.broker = robot, link, layer, broker
        self.host = host
        self.emit, self.save_progress = host.emit, host.save_progress
        self.teleop = False
        self.actions: dict[str, _Tracked] = {}

    def setup(self) -> None:
        """Start hook: register, then take this robot's open actions back from the journal.

        Registering first means a request journaled after the journal read below is
        told to this incarnation; one journaled before is restored here (and a late
        StartAction for it is ignored).
        """
        first = self.ctx.incarnation == 1
        self.host.register(self.robot, self.actor_ref)
        entries, self.teleop = self.host.restore(self.robot, first)
        why = "an RCL restart" if first else f"a restart of robot actor {self.robot}"
        for entry in entries:
            self._start(StartAction(entry.action, entry.suspended_by, restored=why))

    # -- dispatch ---------------------------------------------------------------------
    def on_receive(self, message: Any) -> Any:
        if isinstance(message, SkillEnded):
            self._skill_ended(message)
        elif isinstance(message, ProgressRecorded):
            self._progress(message)
        elif isinstance(message, StartAction):
            self._start(message)
        elif isinstance(message, Control):
            self._control(message)
        elif isinstance(message, SetTeleop):
            self._set_teleop(message.on)
        elif isinstance(message, _StopDeadline):
            self._deadline(message)
        else:
            log.warning("robot %s: unexpected message %r", self.robot, message)
        return None

    def teardown(self) -> None:
        """Stop or crash: stop every skill, change no state (the journal has them)."""
        refs = [r for t in self.actions.values() for r in t.refs if r is not None]
        for t in self.actions.values():
            if t.stopping and t.stopping.timer:
                t.stopping.timer.cancel()
        for ref in refs:
            try:
                ref.tell(Interrupt())
            except pykka.ActorDeadError:
                pass  # that skill has just ended
        futures = [ref.stop(block=False) for ref in refs]
        try:
            pykka.get_all(futures, timeout=self.layer.interrupt_timeout)
        except pykka.Timeout:
            log.error("robot %s: skills still busy at shutdown; abandoned", self.robot)

    # -- lifecycle --------------------------------------------------------------------
    def _start(self, msg: StartAction) -> None:
        if msg.action.uuid in self.actions:
            return  # restored from the journal already
        t = _Tracked(msg.action.copy(), suspended_by=msg.suspended_by)
        self.actions[t.action.uuid] = t
        if t.action.state is ActionState.SUSPENDED:  # only restored actions come suspended
            keep = t.suspended_by == BY_CONTROL or (self.teleop and
                                                    t.suspended_by == BY_TELEOP)
            if keep:  # re-announce: it is not forgotten
                t.action.reason = f"still suspended ({t.suspended_by}) after {msg.restored}"
                self.emit(t.action.copy(), t.suspended_by)
            else:
                t.suspended_by = ""
                self._run(t, f"resumed after {msg.restored}")
        elif self.teleop:
            self._suspend_now(t, "robot in teleop", BY_TELEOP)
        else:
            self._run(t, f"resumed after {msg.restored}" if msg.restored else "")

    def _run(self, t: _Tracked, reason: str) -> None:
        """Refine the action (again, from its progress) and start its skills."""
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
            self._end(t, ActionState.FAILED, why)
            return
        # The skills start first (the robot moves sooner), RUNNING is journaled and
        # published right after: whatever they report is handled after this method, so
        # the statuses keep their order; a crash in between restores the action anyway.
        t.refs, t.outcomes, t.reasons = [], [None] * len(skills), [""] * len(skills)
        for index, skill in enumerate(skills):
            runner = SkillRunner(snapshot, t.run, index, self.link, self.broker,
                                 self.actor_ref.tell)
            t.refs.append(SkillActor.start(skill, runner, self.actor_ref.tell))
        if t.action.state is not ActionState.RUNNING:
            t.action.transition(ActionState.RUNNING, reason)
            self.emit(t.action.copy(), "")
        elif reason:  # restored while RUNNING: no transition, but say so
            t.action.reason = reason
            self.emit(t.action.copy(), "")
        if not skills:
            self._check(t)

    def _progress(self, msg: ProgressRecorded) -> None:
        t = self.actions.get(msg.uuid)
        if t is None or msg.run != t.run:
            return
        t.action.progress.update(msg.values)
        self.save_progress(msg.uuid, dict(t.action.progress))

    def _skill_ended(self, msg: SkillEnded) -> None:
        t = self.actions.get(msg.uuid)
        if t is None or msg.run != t.run or t.refs[msg.index] is None:
            return  # a skill of an earlier run, or one already abandoned
        t.refs[msg.index] = None
        t.outcomes[msg.index], t.reasons[msg.index] = msg.outcome, msg.reason
        if t.stopping:
            if all(r is None for r in t.refs):
                self._stopped(t)
        else:
            self._check(t)

    def _check(self, t: _Tracked) -> None:
        """Ask the project whether the action is over (default: AND of its skills)."""
        try:
            verdict = self.layer.check_action_status(t.action.copy(), list(t.outcomes))
        except Exception as exc:
            verdict, why = ActionState.FAILED, f"check_action_status raised {exc!r}"
        else:
            why = next((r for r, o in zip(t.reasons, t.outcomes, strict=True)
                        if o is not None and o is not SkillOutcome.SUCCEEDED), "")
        if verdict is None and all(r is None for r in t.refs):
            verdict, why = ActionState.FAILED, "every skill ended without a verdict"
        if verdict is None:
            return
        if verdict not in (ActionState.SUCCEEDED, ActionState.FAILED, ActionState.CANCELLED):
            verdict, why = ActionState.FAILED, f"check_action_status returned {verdict!r}"
        self._stop_skills(t, verdict, why, "")

    def _stop_skills(self, t: _Tracked, target: ActionState, reason: str, by: str) -> None:
        """Interrupt the skills still running, then move to `target`."""
        running = [r for r in t.refs if r is not None]
        if not running:
            t.stopping = _Stopping(target, reason, by)
            self._stopped(t)
            return
        t.stopping = _Stopping(target, reason, by)
        uuid, run = t.action.uuid, t.run
        t.stopping.timer = threading.Timer(
            self.layer.interrupt_timeout, self._tell_deadline, (uuid, run))
        t.stopping.timer.daemon = True
        t.stopping.timer.start()
        for ref in running:
            try:
                ref.tell(Interrupt())
            except pykka.ActorDeadError:
                pass  # ended meanwhile: its SkillEnded is on the way

    def _tell_deadline(self, uuid: str, run: int) -> None:
        try:
            self.actor_ref.tell(_StopDeadline(uuid, run))
        except pykka.ActorDeadError:
            pass

    def _deadline(self, msg: _StopDeadline) -> None:
        t = self.actions.get(msg.uuid)
        if t is None or t.run != msg.run or t.stopping is None:
            return
        for index, ref in enumerate(t.refs):
            if ref is not None:
                log.error("robot %s: skill %d of action %s ignored its interrupt for %.1fs; "
                          "abandoned", self.robot, index, msg.uuid, self.layer.interrupt_timeout)
                self.broker.release_token(f"{msg.uuid}/{msg.run}/{index}")
                ref.stop(block=False)
                t.refs[index], t.outcomes[index] = None, SkillOutcome.INTERRUPTED
        self._stopped(t)

    def _stopped(self, t: _Tracked) -> None:
        """Every skill has ended: complete the pending stop."""
        stop = t.stopping
        assert stop is not None
        if stop.timer:
            stop.timer.cancel()
        t.stopping = None
        if stop.target is not ActionState.SUSPENDED:
            self._end(t, stop.target, stop.reason)
        elif stop.resume_after:
            self._run(t, "")
        else:
            self._suspend_now(t, stop.reason, stop.by)

    def _suspend_now(self, t: _Tracked, reason: str, by: str) -> None:
        t.action.transition(ActionState.SUSPENDED, reason)
        t.suspended_by = by
        if not by.startswith("resource:"):  # only a pre-emption waits for its resource
            self.broker.forget_action(t.action.uuid)
        self.emit(t.action.copy(), by)

    def _end(self, t: _Tracked, state: ActionState, reason: str) -> None:
        t.action.transition(state, reason)
        try:
            self.layer.on_action_end(t.action.copy())
        except Exception as exc:
            log.error("robot %s: on_action_end(%s) raised %r", self.robot, t.action.uuid, exc)
        self.emit(t.action.copy(), "")
        self.broker.forget_action(t.action.uuid)
        del self.actions[t.action.uuid]

    # -- goal management and teleop ---------------------------------------------------------
    def _control(self, msg: Control) -> None:
        t = self.actions.get(msg.uuid)
        if t is None:
            log.info("robot %s: %s for %s ignored: not active", self.robot, msg.command, msg.uuid)
            return
        if msg.command in _END_OF:
            target = _END_OF[msg.command]
            reason = msg.reason or f"{msg.command} by goal management"
            if t.stopping is None:
                self._stop_skills(t, target, reason, msg.by)
            elif t.stopping.target is ActionState.SUSPENDED:
                t.stopping.target, t.stopping.reason = target, reason
                t.stopping.resume_after = False
        elif msg.command == "suspend":
            self._suspend(t, msg.reason or f"suspended by {msg.by}", msg.by)
        elif msg.command == "resume":
            self._resume(t, msg.by)
        else:
            log.warning("robot %s: unknown command %r", self.robot, msg.command)

    def _suspend(self, t: _Tracked, reason: str, by: str) -> None:
        stop = t.stopping
        if t.action.state is ActionState.SUSPENDED:
            if _rank(by) > _rank(t.suspended_by):  # a stronger cause now holds it
                t.suspended_by, t.action.reason = by, reason
                self.emit(t.action.copy(), by)
        elif stop is not None:
            if stop.target is ActionState.SUSPENDED:
                stop.resume_after = False
                if _rank(by) > _rank(stop.by):
                    stop.by, stop.reason = by, reason
        else:
            self._stop_skills(t, ActionState.SUSPENDED, reason, by)

    def _resume(self, t: _Tracked, by: str) -> None:
        stop = t.stopping
        if t.action.state is ActionState.SUSPENDED:
            if by != BY_CONTROL and by != t.suspended_by:
                return  # suspended for another reason, which still holds
            if self.teleop:
                t.suspended_by = BY_TELEOP  # resumes when the teleop ends
                return
            t.suspended_by = ""
            self._run(t, f"resumed by {by}")
        elif (stop is not None and stop.target is ActionState.SUSPENDED
              and by in (BY_CONTROL, stop.by) and not self.teleop):
            stop.resume_after = True

    def _set_teleop(self, on: bool) -> None:
        if on == self.teleop:
            return
        self.teleop = on
        for t in list(self.actions.values()):
            if on:
                self._suspend(t, "robot in teleop", BY_TELEOP)
            else:
                self._resume(t, BY_TELEOP)
