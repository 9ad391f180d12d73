"""The base class of actors under an `ActorSupervisor`, and what they know of it.

A `SupervisedActor` reports its own failures to its supervisor: an exception escaping
any handler (tell, ask or proxy call) or the `setup` start hook fails the actor, except
the `caller_errors` it declares, which an ask returns to its caller (like a gen_server
replying an error). Raising `LinkDown` fails it with the distinct cause "link_down";
raising `Escalation` (something the actor supervises gave up: a skill past its restart
budget) fails it with the cause "escalated". Each start is a new incarnation with a
fresh object: `setup` rebuilds the state.
"""

from __future__ import annotations

import logging
import threading
import time
from collections.abc import Callable
from dataclasses import dataclass, field
from typing import TYPE_CHECKING, Any, ClassVar, Literal

import pykka

from mrss.supervision.pooled import (
    TURN_MESSAGES,
    TURN_THREADS,
    PooledInbox,
    answer_dead,
    run_envelope,
)
from mrss.supervision.reason import Cause, ExitReason
from mrss.supervision.spec import ChildKind, ChildSpec, Restart
from mrss.supervision.threads import ACTOR_THREADS

if TYPE_CHECKING:
    from mrss.supervision.events import SupEvents

log = logging.getLogger("mrss.supervision.actors")


class LinkDown(Exception):  # noqa: N818 - reads as the event it is: raise LinkDown(...)
    """Raise from a robot actor when its robot is unreachable (not a bug in our code)."""


class Escalation(Exception):  # noqa: N818 - reads as the event it is
    """Raise from a supervised actor when a child of its own (a skill) escalated to it."""


@dataclass(frozen=True)
class ChildDown:
    """Message to a supervisor: incarnation `inc` of `child` stopped for `reason`."""

    child: str
    inc: int
    reason: ExitReason


@dataclass(frozen=True)
class ChildUp:
    """Message to a supervisor: incarnation `inc` of `child` finished its start hook."""

    child: str
    inc: int


class InjectedFault(Exception):  # noqa: N818 - it is the fault, raised on purpose
    """Raised inside a handler by the `CrashNow` fault message."""


@dataclass(frozen=True)
class CrashNow:
    """Fault message: the handler receiving it raises InjectedFault (crash-in-handler)."""

    detail: str = "injected crash"


@dataclass(frozen=True)
class BlockFor:
    """Fault message: the handler receiving it blocks for `seconds` (a hang)."""

    seconds: float


class Wake:
    """A no-op message that unblocks an actor's inbox so it notices it was abandoned."""


@dataclass
class Liveness:
    """Shared between one incarnation and its supervisor: busy time, and kill switches."""

    busy_since: float | None = None
    settled: threading.Event = field(default_factory=threading.Event)  # start hook done
    started_ok: bool = False
    stopping: bool = False  # its supervisor asked it to stop
    abandoned: bool = False  # its supervisor gave up on it (watchdog, brutal kill)
    reported: bool = False  # it already told its supervisor that it is down
    actor: SupervisedActor | None = None
    lock: threading.Lock = field(default_factory=threading.Lock)

    def claim_report(self) -> bool:
        """True exactly once: whoever gets it reports this incarnation's end."""
        with self.lock:
            if self.reported or self.abandoned or self.stopping:
                return False
            self.reported = True
            return True


@dataclass(frozen=True)
class ActorContext:
    """A supervised actor's place in the tree: id, incarnation, supervisor, events."""

    child: str
    incarnation: int
    supervisor: pykka.ActorRef[Any] | None = None
    events: SupEvents | None = None
    liveness: Liveness = field(default_factory=Liveness)

    @staticmethod
    def standalone(child: str = "actor") -> ActorContext:
        """A context for running a supervised actor with no supervisor (tests, tools)."""
        return ActorContext(child=child, incarnation=1)


class SupervisedActor(pykka.ThreadingActor):
    """Base of actors under an ActorSupervisor; override `setup` and `teardown`."""

    caller_errors: ClassVar[tuple[type[Exception], ...]] = ()
    #: Run only while there is mail, on the shared threads of mrss.supervision.pooled,
    #: instead of on a thread of its own for its whole life (the RCL's robot actors).
    pooled: ClassVar[bool] = False

    def __init__(self, ctx: ActorContext | None = None) -> None:
        super().__init__()
        self.ctx = ctx or ActorContext.standalone(type(self).__name__)
        self.ctx.liveness.actor = self
        if self.pooled:
            self.actor_inbox = PooledInbox(
                self._pooled_turn, lambda envelope: answer_dead(self, envelope))
            self._actor_ref = pykka.ActorRef(self)  # it holds the inbox it was made with

    def _start_actor_loop(self) -> None:
        if self.pooled:
            TURN_THREADS.submit(self._pooled_start)
            return
        ACTOR_THREADS.submit(self._actor_loop)  # a pre-started thread: fast restarts

    def _pooled_start(self) -> None:
        """A pooled actor's start hook, then its first turn, on a pool thread."""
        self._actor_loop_setup()
        inbox = self.actor_inbox
        assert isinstance(inbox, PooledInbox)
        inbox.open()
        self._pooled_turn()

    def _pooled_turn(self) -> None:
        """Handle the mail waiting (up to TURN_MESSAGES), as pykka's loop would."""
        inbox = self.actor_inbox
        assert isinstance(inbox, PooledInbox)
        for _ in range(TURN_MESSAGES):
            if self.actor_stopped.is_set():
                for envelope in inbox.end():
                    answer_dead(self, envelope)
                return
            envelope = inbox.take()
            if envelope is None:
                return
            run_envelope(self, envelope)
        inbox.again()

    # -- hooks for subclasses ----------------------------------------------------------
    def setup(self) -> None:
        """Start hook, run in the actor's thread before any message: (re)build state."""

    def teardown(self) -> None:
        """Stop hook, run in the actor's thread when it stops or fails: release resources."""

    def link_down(self, reason: str) -> None:
        """Fail this actor because its robot link is down (call from the actor's thread)."""
        raise LinkDown(reason)

    # -- pykka hooks ---------------------------------------------------------------------
    def on_start(self) -> None:
        live = self.ctx.liveness
        live.busy_since = time.monotonic()
        try:
            self.setup()
            live.started_ok = True
        except Exception as exc:
            self._failed(exc)
            raise
        finally:
            live.busy_since = None
            live.settled.set()
        if self.ctx.supervisor is not None and not live.abandoned:
            self.ctx.supervisor.tell(ChildUp(self.ctx.child, self.ctx.incarnation))

    def on_stop(self) -> None:
        try:
            self.teardown()
        finally:
            if self.ctx.liveness.claim_report():
                self._report(ExitReason(Cause.NORMAL, "stopped itself"))

    def on_failure(self, exception_type: Any, exception_value: Any, traceback: Any) -> None:
        if isinstance(exception_value, Exception):
            self._failed(exception_value)

    def _handle_receive(self, message: Any) -> Any:
        if isinstance(message, Wake):
            if self.ctx.liveness.abandoned:
                self.actor_stopped.set()
            return None
        live = self.ctx.liveness
        live.busy_since = time.monotonic()
        try:
            if isinstance(message, CrashNow):
                raise InjectedFault(message.detail)
            if isinstance(message, BlockFor):
                time.sleep(message.seconds)  # the fault is the blocking itself
                return None
            return super()._handle_receive(message)
        except self.caller_errors:
            raise
        except Exception as exc:
            self._failed(exc)
            raise
        finally:
            live.busy_since = None

    # -- internals -------------------------------------------------------------------------
    def _failed(self, exc: Exception) -> None:
        if not self.ctx.liveness.claim_report():
            return
        self.actor_stopped.set()
        pykka.ActorRegistry.unregister(self.actor_ref)
        try:
            self.teardown()
        except Exception:
            log.exception("teardown of %s failed after a crash", self.ctx.child)
        if isinstance(exc, LinkDown):
            reason = ExitReason(Cause.LINK_DOWN, str(exc))
        elif isinstance(exc, Escalation):
            reason = ExitReason(Cause.ESCALATED, str(exc))
        else:
            reason = ExitReason.crashed(exc)
        self._report(reason)

    def _report(self, reason: ExitReason) -> None:
        if self.ctx.supervisor is not None:
            self.ctx.supervisor.tell(ChildDown(self.ctx.child, self.ctx.incarnation, reason))

    def _abandon(self) -> None:
        """Called by the supervisor from its thread: this incarnation is dead to it."""
        with self.ctx.liveness.lock:
            self.ctx.liveness.abandoned = True
        try:
            self.actor_ref.tell(Wake())  # unblock its inbox so its thread can end
        except pykka.ActorDeadError:
            pass
        self.actor_stopped.set()
        pykka.ActorRegistry.unregister(self.actor_ref)


ActorFactory = Callable[[ActorContext], pykka.ActorRef[Any]]

@dataclass(frozen=True)
class ActorStart:
    """How to start an actor child: a factory taking its context, plus limits.

    `watchdog` is the seconds one handler (or the start hook) may block before the
    child counts as hung; `start_timeout` bounds the start hook when there is none.
    """

    factory: ActorFactory
    watchdog: float | None = None
    start_timeout: float = 5.0

def actor_child(
    id: str, factory: ActorFactory, *, restart: Restart | str = Restart.PERMANENT,
    shutdown: float | Literal["kill"] = 5.0, kind: ChildKind | str = ChildKind.WORKER,
    watchdog: float | None = None, start_timeout: float = 5.0,
) -> ChildSpec[ActorStart]:
    """A ChildSpec for an actor, e.g. `actor_child("uav1", lambda c: Robot.start(c))`."""
    return ChildSpec(id, ActorStart(factory, watchdog, start_timeout),
                     restart=Restart(restart), shutdown=shutdown, kind=ChildKind(kind))
