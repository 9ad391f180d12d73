"""Actor supervision: pykka actors under a supervisor driven by the shared RestartPolicy.

An `ActorSupervisor` is itself a supervised actor, so supervisors nest (robot actor ->
skill actors) and a nested one that exceeds its intensity stops its children and fails
to its parent with the cause "escalated". A root supervisor that gives up calls its
`on_give_up` callback. With `on_exceeded = quarantine` (robot supervisors) only the
offending child is stopped, a `sup.quarantine` event names it, and it is retried after
probation (`sup.release`). A watchdog thread fails children whose handler blocks past
their limit; the blocked thread is abandoned (threads cannot be killed) and a new
incarnation takes over. Children should `tell` their supervisor, never `ask` it.
"""

from __future__ import annotations

import os
import random
import threading
import time
from collections.abc import Callable, Iterable, Sequence
from dataclasses import dataclass
from typing import Any

import pykka

from mrss.errors import SupervisionError
from mrss.supervision import events as ev
from mrss.supervision.child_states import ChildCause, move
from mrss.supervision.events import Publish, SupEvents
from mrss.supervision.policy import Action, Decision, RestartPolicy
from mrss.supervision.reason import Cause, ExitReason
from mrss.supervision.spec import ChildKind, ChildSpec, SupervisorSpec
from mrss.supervision.status import ChildState, ChildStatus
from mrss.supervision.supervised import (
    ActorContext,
    ActorStart,
    BlockFor,
    ChildDown,
    ChildUp,
    CrashNow,
    LinkDown,
    Liveness,
    SupervisedActor,
    actor_child,
)
from mrss.supervision.threads import SCHEDULER, Scheduled

__all__ = [
    "ActorContext", "ActorStart", "ActorSupervisor", "BlockFor", "CrashNow", "LinkDown",
    "SupervisedActor", "actor_child",
]

@dataclass(frozen=True)
class _RestartDue:
    token: int
    ids: tuple[str, ...]

@dataclass(frozen=True)
class _StartCheck:
    child: str
    inc: int
    limit: float


@dataclass(frozen=True)
class _ReleaseDue:
    child: str
    token: int

@dataclass
class _Child:
    spec: ChildSpec[ActorStart]
    state: ChildState = ChildState.STOPPED
    ref: pykka.ActorRef[Any] | None = None
    liveness: Liveness | None = None
    incarnation: int = 0
    up_since: float = 0.0
    last_reason: str = ""
    token: int = 0

class ActorSupervisor(SupervisedActor):
    """Starts actor children in order, restarts them by policy, stops them in reverse."""

    caller_errors = (SupervisionError,)

    def __init__(
        self, spec: SupervisorSpec, children: Iterable[ChildSpec[ActorStart]] = (),
        *, ctx: ActorContext | None = None, name: str | None = None,
        publish: Publish | None = None, on_give_up: Callable[[ExitReason], None] | None = None,
        clock: Callable[[], float] = time.monotonic, rand: Callable[[], float] = random.random,
    ) -> None:
        super().__init__(ctx or ActorContext.standalone(name or "supervisor"))
        self.name = name or self.ctx.child
        parent_events = self.ctx.events
        self.events = parent_events.child(self.name) if parent_events else \
            SupEvents(self.name, publish)
        self.spec = spec
        self._on_give_up = on_give_up
        self._clock = clock
        self._children: dict[str, _Child] = {}
        self._policy = RestartPolicy(spec, clock=clock, rand=rand)
        self._tokens = 0
        self._timers: list[Scheduled] = []
        self._watchdog_stop = threading.Event()
        self._watchdog: threading.Thread | None = None
        self._given_up = False
        for child in children:
            self._add(child)

    # -- public API (call through the proxy: sup.proxy().add_child(spec).get()) ---------
    def add_child(self, spec: ChildSpec[ActorStart]) -> pykka.ActorRef[Any] | None:
        """Append a child and start it; returns its ref (None if its start failed)."""
        self._add(spec)
        self._start_child(spec.id)
        return self._children[spec.id].ref

    def remove_child(self, child: str) -> None:
        """Stop a child by its shutdown rule and forget it."""
        self._get(child)
        self._stop_child(child)
        del self._children[child]
        self._policy.remove_child(child)

    def ref_of(self, child: str) -> pykka.ActorRef[Any] | None:
        """The current incarnation's ref, or None while the child is down."""
        c = self._get(child)
        return c.ref if c.state in (ChildState.RUNNING, ChildState.STARTING) else None

    def which_children(self) -> list[str]:
        return list(self._children)

    def tree(self) -> ChildStatus:
        """This supervisor and its children (nested supervisors included), as plain data."""
        now = self._clock()
        nodes = []
        for c in self._children.values():
            nested = c.liveness.actor if c.liveness else None
            if isinstance(nested, ActorSupervisor) and c.ref is not None \
                    and c.state is ChildState.RUNNING:
                try:
                    node: ChildStatus = c.ref.proxy().tree().get(timeout=1.0)
                    nodes.append(_with(node, c, now, self._policy.restarts(c.spec.id),
                                       self._policy.budget(c.spec.id, now)))
                    continue
                except (pykka.ActorDeadError, pykka.Timeout):
                    pass
            nodes.append(ChildStatus(
                id=c.spec.id, kind=c.spec.kind.value, state=c.state.value,
                pid=os.getpid() if c.ref else 0, incarnation=c.incarnation,
                restarts=self._policy.restarts(c.spec.id),
                budget=self._policy.budget(c.spec.id, now),
                uptime=now - c.up_since if c.state is ChildState.RUNNING else 0.0,
                last_reason=c.last_reason,
            ))
        return ChildStatus(id=self.name, kind=ChildKind.SUPERVISOR.value, state="running",
                           pid=os.getpid(), incarnation=self.ctx.incarnation,
                           strategy=self.spec.strategy.value, children=tuple(nodes))

    # -- lifecycle -------------------------------------------------------------------------
    def setup(self) -> None:
        for child in list(self._children):
            self._start_child(child)
        limits = [c.spec.start.watchdog for c in self._children.values() if c.spec.start.watchdog]
        if limits:
            self._start_watchdog(min(limits))

    def teardown(self) -> None:
        self._watchdog_stop.set()
        for timer in self._timers:
            timer.cancel()
        for child in reversed(list(self._children)):
            self._stop_child(child)

    def on_receive(self, message: Any) -> Any:
        if isinstance(message, ChildUp):
            self._child_up(message)
        elif isinstance(message, ChildDown):
            self._child_down(message)
        elif isinstance(message, _StartCheck):
            self._start_check(message)
        elif isinstance(message, _RestartDue):
            self._start_group(message.ids, message.token, wait=len(message.ids) > 1)
        elif isinstance(message, _ReleaseDue):
            self._release(message)
        else:
            return super().on_receive(message)
        return None

    # -- decisions -------------------------------------------------------------------------
    def _child_up(self, msg: ChildUp) -> None:
        c = self._children.get(msg.child)
        if c is not None and c.incarnation == msg.inc and c.state is ChildState.STARTING:
            c.state, c.up_since = move(c.state, ChildCause.READY, msg.child), self._clock()
            self._policy.child_started(msg.child)
            self.events.emit(ev.START, msg.child, pid=os.getpid(), inc=c.incarnation)

    def _start_check(self, msg: _StartCheck) -> None:
        c = self._children.get(msg.child)
        if c is not None and c.incarnation == msg.inc and c.state is ChildState.STARTING:
            self._child_down(ChildDown(msg.child, msg.inc, ExitReason(
                Cause.HUNG, f"start hook still running after {msg.limit:g}s")))

    def _child_down(self, msg: ChildDown) -> None:
        c = self._children.get(msg.child)
        if c is None or msg.inc != c.incarnation or c.state not in (
                ChildState.RUNNING, ChildState.STARTING):
            return  # a dead incarnation's late report
        if c.liveness is not None and c.liveness.actor is not None \
                and c.liveness.actor.actor_ref.is_alive():
            c.liveness.actor._abandon()  # hung: the thread lives on, the child does not
        c.ref = None
        c.state = move(c.state, ChildCause.EXITED, msg.child)
        c.last_reason = str(msg.reason)
        self.events.emit(ev.EXIT, msg.child, pid=os.getpid(), reason=str(msg.reason),
                         inc=msg.inc)
        running = {k for k, v in self._children.items()
                   if v.state in (ChildState.RUNNING, ChildState.STARTING)}
        self._apply(self._policy.child_exited(msg.child, msg.reason, running=running))

    def _apply(self, d: Decision) -> None:
        if d.action is Action.LEAVE:
            return
        if d.action is Action.ESCALATE:
            self._escalate(d)
            return
        if d.action is Action.QUARANTINE:
            c = self._children[d.child]
            c.state = move(c.state, ChildCause.GIVEN_UP, d.child)
            c.token = self._next_token()
            self.events.emit(ev.QUARANTINE, d.child, reason=str(d.reason), count=d.count,
                             robot=d.child, probation=d.delay, note=d.note)
            self._later(d.delay, _ReleaseDue(d.child, c.token))
            return
        for sid in d.stop:
            self._stop_child(sid)
        token = self._next_token()
        for rid in d.restart:
            c = self._children[rid]
            c.state, c.token = move(c.state, ChildCause.RESTART_DUE, rid), token
        self.events.emit(ev.RESTART, d.child, reason=str(d.reason), count=d.count,
                         delay=round(d.delay, 3), group=list(d.restart))
        if d.delay <= 0:
            self._start_group(d.restart, token, wait=len(d.restart) > 1)
        else:
            self._later(d.delay, _RestartDue(token, d.restart))

    def _escalate(self, d: Decision) -> None:
        for sid in d.stop:
            self._stop_child(sid)
        for cid, c in self._children.items():
            c.state = move(c.state, ChildCause.ABANDONED, cid)
        why = f"child {d.child} ({d.reason}): {d.note}"
        self._given_up = True
        if self.ctx.supervisor is not None:
            self.events.emit(ev.ESCALATE, d.child, reason=str(d.reason), note=d.note)
            if self.ctx.liveness.claim_report():
                self._report(ExitReason(Cause.ESCALATED, why))
        else:
            self.events.emit(ev.GIVE_UP, d.child, reason=str(d.reason), note=d.note)
            if self._on_give_up is not None:
                self._on_give_up(ExitReason(Cause.ESCALATED, why))
        self.stop()  # after this message: the supervisor ends with its children

    def _release(self, msg: _ReleaseDue) -> None:
        c = self._children.get(msg.child)
        if c is None or c.state is not ChildState.QUARANTINED or c.token != msg.token:
            return
        self._policy.release(msg.child)
        self.events.emit(ev.RELEASE, msg.child, robot=msg.child)
        self._start_child(msg.child)

    # -- starting and stopping ---------------------------------------------------------------
    def _start_group(self, ids: Sequence[str], token: int, wait: bool = True) -> None:
        for cid in ids:
            c = self._children.get(cid)
            if c is not None and c.state is ChildState.WAITING and c.token == token \
                    and not self._given_up:
                self._start_child(cid, wait)

    def _start_child(self, child: str, wait: bool = True) -> None:
        """Start a new incarnation; with `wait`, block until its start hook is done.

        Siblings started in sequence wait, so each finds the earlier ones set up; a lone
        restart does not, so the supervisor keeps serving while the child sets up
        (ChildUp marks it running; a _StartCheck enforces the time limit).
        """
        c = self._children[child]
        c.incarnation += 1
        live = Liveness()
        ctx = ActorContext(child=child, incarnation=c.incarnation, supervisor=self.actor_ref,
                           events=self.events, liveness=live)
        c.liveness, c.state = live, move(c.state, ChildCause.STARTED, child)
        try:
            c.ref = c.spec.start.factory(ctx)
            if live.actor is None:
                raise SupervisionError(
                    f"factory of {child} must start a SupervisedActor with the given ctx")
        except Exception as exc:
            self.actor_ref.tell(ChildDown(child, c.incarnation, ExitReason.crashed(exc)))
            return
        limit = c.spec.start.watchdog or c.spec.start.start_timeout
        if not wait:
            self._later(limit, _StartCheck(child, c.incarnation, limit))
            return
        if not live.settled.wait(limit):
            self.actor_ref.tell(ChildDown(child, c.incarnation, ExitReason(
                Cause.HUNG, f"start hook still running after {limit:g}s")))
            return
        if live.started_ok:
            self._child_up(ChildUp(child, c.incarnation))

    def _stop_child(self, child: str) -> None:
        c = self._children[child]
        live, ref = c.liveness, c.ref
        if c.state in (ChildState.WAITING, ChildState.QUARANTINED):
            c.state = move(c.state, ChildCause.STOP_ASKED, child)
        if ref is None or live is None or live.actor is None or \
                c.state not in (ChildState.RUNNING, ChildState.STARTING):
            return
        c.state = move(c.state, ChildCause.STOP_ASKED, child)
        with live.lock:
            live.stopping = True
        reason = ExitReason(Cause.SHUTDOWN, "stopped by supervisor")
        if c.spec.shutdown_timeout <= 0:
            live.actor._abandon()
            reason = ExitReason(Cause.SHUTDOWN, "killed (shutdown = kill)")
        else:
            try:
                ref.stop(block=True, timeout=c.spec.shutdown_timeout)
            except pykka.Timeout:
                live.actor._abandon()
                reason = ExitReason(Cause.SHUTDOWN,
                                    f"killed after shutdown {c.spec.shutdown_timeout:g}s")
        c.ref, c.state, c.last_reason = None, move(c.state, ChildCause.STOPPED, child), str(reason)
        self._policy.child_stopped(child)
        self.events.emit(ev.EXIT, child, pid=os.getpid(), reason=str(reason),
                         inc=c.incarnation)

    # -- helpers -----------------------------------------------------------------------------
    def _add(self, spec: ChildSpec[ActorStart]) -> None:
        if not isinstance(spec.start, ActorStart):
            raise SupervisionError(f"child {spec.id}: start must be an ActorStart")
        self._policy.add_child(spec)
        self._children[spec.id] = _Child(spec)

    def _get(self, child: str) -> _Child:
        try:
            return self._children[child]
        except KeyError:
            raise SupervisionError(f"{self.name} has no child {child!r}") from None

    def _next_token(self) -> int:
        self._tokens += 1
        return self._tokens

    def _later(self, delay: float, message: object) -> None:
        ref = self.actor_ref

        def fire() -> None:
            try:
                ref.tell(message)
            except pykka.ActorDeadError:
                pass

        self._timers = [t for t in self._timers if not t.cancelled and t.due > self._clock()]
        self._timers.append(SCHEDULER.call_later(delay, fire))

    def _start_watchdog(self, shortest: float) -> None:
        interval = max(0.001, shortest / 4)

        def watch() -> None:
            while not self._watchdog_stop.wait(interval):
                now = time.monotonic()
                for c in list(self._children.values()):
                    live, limit = c.liveness, c.spec.start.watchdog
                    busy = live.busy_since if live else None
                    if limit and busy is not None and now - busy > limit \
                            and c.state is ChildState.RUNNING:
                        self._tell_hung(c, now - busy, limit)

        self._watchdog = threading.Thread(target=watch, name=f"watchdog-{self.name}",
                                          daemon=True)
        self._watchdog.start()

    def _tell_hung(self, c: _Child, busy: float, limit: float) -> None:
        try:
            self.actor_ref.tell(ChildDown(c.spec.id, c.incarnation, ExitReason(
                Cause.HUNG, f"handler blocked {busy:.3f}s > watchdog {limit:g}s")))
        except pykka.ActorDeadError:
            self._watchdog_stop.set()

def _with(node: ChildStatus, c: _Child, now: float, restarts: int,
          budget: tuple[int, int, float]) -> ChildStatus:
    """A nested supervisor's own status, with what its parent knows of it."""
    return ChildStatus(
        id=c.spec.id, kind=node.kind, state=c.state.value, pid=node.pid,
        incarnation=c.incarnation, restarts=restarts, budget=budget,
        uptime=now - c.up_since, last_reason=c.last_reason, strategy=node.strategy,
        children=node.children,
    )
