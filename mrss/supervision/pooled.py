"""Actors without a thread of their own: a shared pool runs an actor only while it has mail.

A pykka `ThreadingActor` holds a thread for its whole life, blocked on its inbox while it
has nothing to do. The RCL runs one actor per robot, so a fleet of 400 robots kept 400
threads waiting (and their stacks) for the few actors that have work at any moment. A
pooled actor's inbox (`PooledInbox`) instead hands the actor's *turn* to a shared pool
(`TURN_THREADS`) when a message arrives and it has no turn queued or running; a turn
handles the messages waiting, in order, then gives the thread back. So:

* messages of one actor are still handled one at a time, in the order they came, and
  never before its start hook (`on_start`) returned: what arrives meanwhile waits;
* a handler may still block (wait for a skill to stop): the pool starts another thread
  when none is idle, so other actors never wait behind it, and idle threads beyond a
  couple of spares end after `IDLE_TIMEOUT_S` (the start hooks of a whole fleet, run
  at once when the RCL starts, leave no threads behind);
* a turn handles at most `TURN_MESSAGES` messages and then queues the actor's next turn
  behind the others', so one busy actor cannot keep a thread from the rest;
* when the actor stopped, the turn answers what is left as pykka does (an ask gets
  `ActorDeadError`, a stop request None), and so is a message that comes later.

What a message does, how failures are reported and how stop works are pykka's own
(`Actor._handle_receive`, `_handle_failure`, `on_failure`): `run_envelope` is the body of
pykka's actor loop, one message at a time.
"""

from __future__ import annotations

import logging
import queue
import sys
import threading
from collections import deque
from collections.abc import Callable
from typing import Any

import pykka
from pykka import messages

from mrss.supervision.threads import ThreadPool

log = logging.getLogger("mrss.supervision.pooled")

TURN_MESSAGES = 32  # messages one turn handles before the actor queues its next turn
IDLE_TIMEOUT_S = 2.0  # an idle pool thread beyond the spares ends after this long

#: The threads that run pooled actors' turns (a thread per turn running, plus spares).
TURN_THREADS = ThreadPool(spare=2, idle_timeout=IDLE_TIMEOUT_S)


class PooledInbox:
    """An actor's inbox that asks for the actor's turn when mail arrives (module doc).

    `put`, `empty` and `get` are what pykka's `ActorRef` and teardown use; `take` is the
    turn's: the next message, or None, which also ends the turn (atomically: a message
    put after it starts a new one).
    """

    def __init__(self, turn: Callable[[], None], closed: Callable[[Any], None]) -> None:
        self._turn = turn
        self._closed = closed
        self._items: deque[Any] = deque()
        self._lock = threading.Lock()
        self._open = False  # the start hook has returned: mail may start a turn
        self._scheduled = False  # a turn is queued or running
        self._ended = False  # the actor has stopped: mail is answered at once

    def put(self, item: Any, block: bool = True, timeout: float | None = None) -> None:
        with self._lock:
            if not self._ended:
                self._items.append(item)
                if self._scheduled or not self._open:
                    return
                self._scheduled = True
        if self._ended:
            self._closed(item)
            return
        TURN_THREADS.submit(self._turn)

    def empty(self) -> bool:
        with self._lock:
            return not self._items

    def get(self, block: bool = True, timeout: float | None = None) -> Any:
        with self._lock:
            if not self._items:
                raise queue.Empty
            return self._items.popleft()

    def qsize(self) -> int:
        with self._lock:
            return len(self._items)

    def open(self) -> None:
        """The start hook returned: the caller's thread now runs the first turn."""
        with self._lock:
            self._open = self._scheduled = True

    def take(self) -> Any | None:
        """The next message of this turn, or None: the turn ends."""
        with self._lock:
            if self._items:
                return self._items.popleft()
            self._scheduled = False
            return None

    def again(self) -> None:
        """The turn handled its share: queue the next one behind the other actors'."""
        TURN_THREADS.submit(self._turn)

    def end(self) -> list[Any]:
        """The actor stopped: what is left, and later mail answered at once."""
        with self._lock:
            self._ended = True
            left = list(self._items)
            self._items.clear()
            return left


def run_envelope(actor: pykka.Actor, envelope: Any) -> None:
    """Handle one message as pykka's actor loop does (its reply, or its failure)."""
    try:
        response = actor._handle_receive(envelope.message)
        if envelope.reply_to is not None:
            envelope.reply_to.set(response)
    except Exception:
        if envelope.reply_to is not None:
            log.info("Exception returned from %s to caller:", actor, exc_info=sys.exc_info())
            envelope.reply_to.set_exception()
        else:
            actor._handle_failure(*sys.exc_info())
            try:
                actor.on_failure(*sys.exc_info())
            except Exception:
                actor._handle_failure(*sys.exc_info())
    except BaseException:
        log.debug("%r in %s. Stopping all actors.", sys.exc_info()[1], actor)
        actor._stop()
        pykka.ActorRegistry.stop_all()


def answer_dead(actor: pykka.Actor, envelope: Any) -> None:
    """A message the stopped actor will never handle: answered as pykka's teardown does."""
    if envelope.reply_to is None:
        return
    if isinstance(envelope.message, messages._ActorStop):
        envelope.reply_to.set(None)
    else:
        envelope.reply_to.set_exception(exc_info=(
            pykka.ActorDeadError,
            pykka.ActorDeadError(f"{actor.actor_ref} stopped before handling the message"),
            None))
