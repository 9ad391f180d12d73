"""One pykka actor per running skill; the skill's own code runs on a worker thread it owns.

`run` may block on a robot link, so the actor never calls it on its own thread: the
worker drives START -> RUN -> FINISH and reports, while the actor stays free to take an
`StopSkill` (set the flag, move to INTERRUPT, call `terminate()`), even if `run` never
returns. Nothing a skill raises escapes to the robot actor.

Skill restarts (`drive`, mrss/actors/rcl/skill_drive.py) follow the supervision policy
(mrss.supervision.policy.RestartPolicy), with the skill as the one child of a supervisor
`robots/<robot>`: a skill that raises is started again from START after the policy's
backoff (with jitter), at most `max_restarts` times within `restart_period` seconds; one
more crash escalates: the skill fails with the exception's message, and so its action,
and the escalation goes on to the robot's supervisor as a crash of the robot actor
(restarted, its other actions taken back from the journal, and counted in
`max_robot_restarts`: a robot whose skills keep escalating is quarantined). Every
restart is a `sup.restart` event, the escalation a `sup.escalate` event (detail: the
action's uuid). A skill without a restart budget (`max_restarts = 0`, the default) only
fails its action: it has nothing to escalate.

A critical section (`Skill.critical`) is kept here, where the interrupt happens: under
the runner's lock a skill enters one only if not interrupted yet, and a `StopSkill` that
is not urgent, arriving inside it, is remembered and carried out when the section ends
or outlasts its bound. The robot actor is told of every entry, exit and overrun
(`CriticalChanged`): it holds the stop deadline meanwhile and publishes the state.
"""

from __future__ import annotations

import logging
import threading
from collections.abc import Callable, Mapping
from dataclasses import dataclass
from typing import Any

import pykka

from mrss.actors.rcl.action import Action
from mrss.actors.rcl.resources import Holder, ResourceBroker
from mrss.actors.rcl.skill import (
    CriticalSection,
    Skill,
    SkillInterrupted,
    SkillOutcome,
    SkillState,
)
from mrss.actors.rcl.skill_drive import drive
from mrss.errors import ActionError
from mrss.messages import JsonValue
from mrss.supervision.threads import ACTOR_THREADS

log = logging.getLogger("mrss.rcl.skill")



@dataclass(frozen=True)
class SkillReport:
    """To the robot actor: skill `index` of run `run` of action `uuid` is over."""

    uuid: str
    run: int
    index: int
    outcome: SkillOutcome
    reason: str
    cause: str = ""  # the FailureCause of what it raised (failure_causes.py)
    escalated: bool = False  # crashed past its restart budget: the robot actor fails too


@dataclass(frozen=True)
class ProgressRecorded:
    """To the robot actor: a skill recorded progress for its action."""

    uuid: str
    run: int
    values: dict[str, JsonValue]
    forget: tuple[str, ...] = ()  # keys to take out of the progress (a wait that is over)


@dataclass(frozen=True)
class CriticalChanged:
    """To the robot actor: skill `index` entered `section`, left it (None), or held it
    past its bound (`overrun`: from now on it defers no stop)."""

    uuid: str
    run: int
    index: int
    section: CriticalSection | None
    overrun: bool = False


@dataclass(frozen=True)
class StopSkill:
    """To a skill actor: stop the skill (suspend, cancel, pre-emption, shutdown); unless
    `urgent`, a skill inside a critical section stops when the section ends."""

    urgent: bool = False


@dataclass(frozen=True)
class _WorkerDone:
    outcome: SkillOutcome
    reason: str
    escalated: bool = False


Report = Callable[[object], None]
#: The progress keys of an action whose skill waits for a resource (cleared to "" once
#: granted): the resource, and the uuids of the actions it waits behind, comma-separated.
QUEUED_FOR, BEHIND = "queued_for", "behind"


class SkillRunner:
    """The runtime a skill sees (mrss.api.SkillRuntime): link, flag, progress, resources."""

    def __init__(self, action: Action, run: int, index: int, link: Any,
                 broker: ResourceBroker, report: Report,
                 publish: Callable[[Any], object] | None = None,
                 data: Callable[[Mapping[str, JsonValue]], bool] | None = None) -> None:
        self.action = action
        self._data = data  # where the skill's robot data goes (the layer's publish_data)
        self.publish = publish  # where the skill's sup.* events go
        self.link = link
        self.run = run
        self.index = index
        self.interrupt_event = threading.Event()
        self.lock = threading.Lock()
        self.token = f"{action.uuid}/{run}/{index}"
        self.cause = ""  # of the last attempt: the FailureCause of what it raised
        self._broker = broker
        self._report = report
        self.section: CriticalSection | None = None  # the open critical section
        self.overrun = False  # it outlasted its bound: it defers nothing any more
        self.stop_deferred = False  # a stop arrived inside it
        self.stop_now: Callable[[], None] = self.interrupt  # the skill actor's interrupt
        self._section_timer: threading.Timer | None = None

    def enter_critical(self, section: CriticalSection) -> None:
        with self.lock:
            if self.interrupt_event.is_set():
                raise SkillInterrupted(f"interrupted before critical section "
                                       f"{section.name!r}")
            if self.section is not None:
                raise ActionError(f"critical section {section.name!r} inside "
                                  f"{self.section.name!r}: sections do not nest",
                                  uuid=self.action.uuid)
            self.section, self.overrun, self.stop_deferred = section, False, False
            timer = threading.Timer(section.bound, self._overran, (section,))
            timer.daemon = True
            self._section_timer = timer
        timer.start()
        self._tell(CriticalChanged(self.action.uuid, self.run, self.index, section))

    def leave_critical(self) -> None:
        with self.lock:
            section, self.section = self.section, None
            if section is None:
                return
            if self._section_timer is not None:
                self._section_timer.cancel()
                self._section_timer = None
            deferred, self.stop_deferred = self.stop_deferred, False
        self._tell(CriticalChanged(self.action.uuid, self.run, self.index, None))
        if deferred:
            log.info("skill %s: critical section %r ended; the deferred stop applies",
                     self.token, section.name)
            self.stop_now()

    def defers(self, urgent: bool) -> bool:
        """Under `lock`: whether a stop waits for the open critical section (remembered)."""
        if urgent or self.section is None or self.overrun:
            return False
        self.stop_deferred = True
        return True

    def _overran(self, section: CriticalSection) -> None:
        with self.lock:
            if self.section is not section:
                return
            self.overrun = True
            deferred, self.stop_deferred = self.stop_deferred, False
        log.error("skill %s: critical section %r held past its bound %gs; stops no longer "
                  "wait for it", self.token, section.name, section.bound)
        self._tell(CriticalChanged(self.action.uuid, self.run, self.index, section,
                                   overrun=True))
        if deferred:
            self.stop_now()

    def _tell(self, message: object) -> None:
        try:
            self._report(message)
        except pykka.ActorDeadError:
            log.info("skill %s: %r not told, robot actor stopped", self.token, message)

    def record_progress(self, values: Mapping[str, JsonValue],
                        forget: tuple[str, ...] = ()) -> None:
        try:
            self._report(ProgressRecorded(self.action.uuid, self.run, dict(values), forget))
        except pykka.ActorDeadError:
            log.warning("skill %s: progress %r lost, robot actor stopped", self.token, values)

    def publish_data(self, data: Mapping[str, JsonValue]) -> bool:
        if self._data is None:
            log.warning("skill %s: robot data %r not sent, no bus", self.token, data)
            return False
        return self._data(data)

    def acquire(self, resource: str, timeout: float | None) -> None:
        """Take `resource`; while waiting for it the action's progress says so
        (`queued_for`, `behind`): it is not running yet, and observers must not say it is."""
        holder = Holder(self.token, self.action.uuid, self.action.priority)
        waited = []

        def waiting(behind: list[str]) -> None:
            waited.append(True)
            self.record_progress({QUEUED_FOR: resource, BEHIND: ",".join(behind)})

        self._broker.acquire(resource, holder, self.interrupt_event, timeout, on_wait=waiting)
        if waited:  # granted: the wait leaves no trace in the action's progress
            self.record_progress({}, forget=(QUEUED_FOR, BEHIND))

    def release(self, resource: str) -> None:
        self._broker.release(resource, self.token)

    def release_all(self) -> None:
        self._broker.release_token(self.token)

    def interrupt(self) -> None:
        self.interrupt_event.set()
        self._broker.wake(self.token)


class SkillActor(pykka.ThreadingActor):
    """Owns one skill's worker thread; reports SkillReport to its robot actor.

    The actor loop and the worker both run on pre-started pool threads, which an
    abandoned skill never keeps the process alive with: starting a thread waits until
    it runs, which on a busy machine cost milliseconds per skill start.
    """

    def __init__(self, skill: Skill, runner: SkillRunner, report: Report) -> None:
        super().__init__()
        self.skill = skill
        self.runner = runner
        self.report = report
        runner.stop_now = lambda: self._interrupt(urgent=True)
        skill._bind(runner)

    def _start_actor_loop(self) -> None:
        # The worker first: it calls the skill's start(), so it takes the first idle
        # thread; its report waits in the inbox until the actor loop runs.
        ACTOR_THREADS.submit(self._work)
        ACTOR_THREADS.submit(self._actor_loop)

    def on_receive(self, message: Any) -> Any:
        if isinstance(message, StopSkill):
            self._interrupt(message.urgent)
        elif isinstance(message, _WorkerDone):
            try:
                self.report(SkillReport(self.runner.action.uuid, self.runner.run,
                                       self.runner.index, message.outcome, message.reason,
                                       self.runner.cause, message.escalated))
            except pykka.ActorDeadError:
                log.info("skill %s ended after its robot actor stopped", self.runner.token)
            self.stop()
        else:
            log.warning("skill actor %s: unexpected message %r", self.runner.token, message)
        return None

    def _interrupt(self, urgent: bool) -> None:
        """Interrupt the skill (on the actor's thread, or the skill's own when a critical
        section that deferred a stop ends)."""
        with self.runner.lock:
            if self.skill.state not in (SkillState.START, SkillState.RUN):
                return
            section = self.runner.section
            if self.runner.defers(urgent):
                log.info("skill %s: stop deferred until critical section %r ends",
                         self.runner.token, section.name if section else "")
                return
            self.skill._set_state(SkillState.INTERRUPT)
        self.runner.interrupt()
        try:
            self.skill.terminate()
        except Exception as exc:  # project code: log, the worker still ends the skill
            log.error("skill %s: terminate() raised %s: %s", self.skill.name,
                      type(exc).__name__, exc)

    def _work(self) -> None:
        escalated = False
        try:
            outcome, reason, escalated = drive(self.skill, self.runner)
        except BaseException as exc:  # noqa: BLE001 - never lose the report
            outcome, reason = SkillOutcome.FAILED, f"{self.skill.name}: {exc!r}"
        finally:
            self.runner.release_all()
        try:
            self.actor_ref.tell(_WorkerDone(outcome, reason, escalated))
        except pykka.ActorDeadError:
            log.info("skill %s ended after being abandoned (%s)", self.runner.token, outcome)
