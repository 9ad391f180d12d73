"""The intake of external events: in order, once, retried while a dependency is down.

Rules, each in one place here:

- **Order.** Events are handled one at a time on the intake's own thread, in the order
  they arrived (never on the MQTT network thread). An event waiting for a dependency
  holds the ones behind it, for at most the retry budget, so an operator's "area a1"
  is never overtaken by their "cancel a1".
- **Attempts** (`mrss.edge.retry`): an attempt runs the adapter's handler inside a
  percept batch, so its percepts go out only when it returns. A transient failure is
  retried with backoff within the budget; a bad payload or a handler bug is not.
- **Outcome and report** (`mrss.actors.events.reports`): every event ends accepted,
  rejected, failed or duplicate, and is reported on the bus, in the log and (rejected,
  failed) back to the sender.
- **Acknowledgement.** The event is acknowledged to the broker (`InboundEvent.acknowledge`,
  the MQTT PUBACK) only once it has an outcome and its percepts are durable: with
  `durable` (the percept channel's `when_durable`), once the reasoner has written every
  percept sent so far to its ledger, so acknowledgements leave in the order the events
  came. An event unfinished, or whose percepts the reasoner has not yet taken, when
  this process stops or dies is not acknowledged: the broker delivers it again to the
  next incarnation (persistent session), whose percepts carry the same ids (an event
  with an id), and the reasoner's ledger takes each id once.
- **Identity and duplicates.** An event whose JSON payload has a string `"id"` is known
  by (topic, id): a second one is a duplicate while the first is in hand or accepted
  (the id of a rejected or failed event may be sent again). An event without an id is
  a duplicate only when the broker marks it redelivered (MQTT DUP) and the same topic
  and payload were seen before. The last `memory` identities are remembered. Percepts
  of an event with an id get message ids derived from (topic, id), so the reasoner
  can tell a redelivery to a new incarnation of this component from a new event.
"""

from __future__ import annotations

import hashlib
import logging
import queue
import threading
import time
from collections import OrderedDict
from collections.abc import Callable
from dataclasses import dataclass

from mrss.actors.events.reports import EventReporter
from mrss.auth.sessions import CREDENTIAL_KEY, claimed_user
from mrss.edge.payloads import PayloadError, decode_json
from mrss.edge.retry import Attempt, RetryPolicy, classify
from mrss.messages import EventStatus, JsonValue
from mrss.runtime.percepts import EventCounters, PerceptPublisher

Work = Callable[[], None]
MAX_ID_LENGTH = 200
DEFAULT_MEMORY = 4096


@dataclass(frozen=True)
class InboundEvent:
    """One message from outside: where it came from, its bytes, how to acknowledge it."""

    topic: str
    payload: bytes
    redelivered: bool = False  # the broker sent it before (MQTT DUP flag)
    acknowledge: Callable[[], object] | None = None


@dataclass(frozen=True)
class Identity:
    """How an event is recognised again: a key, and the sender's id if it gave one."""

    key: str
    event_id: str  # "" without one
    detail: dict[str, JsonValue]

    @property
    def percept_ids(self) -> str | None:
        """The prefix of its percepts' message ids (None: fresh ids)."""
        return f"ev-{self.key}" if self.event_id else None


def identify(event: InboundEvent) -> Identity:
    """The identity of an event: by its payload's `"id"` if any, else by its content."""
    event_id = ""
    detail: dict[str, JsonValue] = {}
    try:  # not Unicode text (a lone surrogate): no id or goal to show from it
        obj = decode_json(event.payload)
    except PayloadError:
        obj = None
    if isinstance(obj, dict):
        given = obj.get("id")
        if isinstance(given, str) and 0 < len(given) <= MAX_ID_LENGTH:
            event_id = given
        goal = obj.get("goal")
        if isinstance(goal, str) and len(goal) <= MAX_ID_LENGTH:
            detail["goal"] = goal
        credential = obj.get(CREDENTIAL_KEY)  # an operator command's author (as claimed:
        if isinstance(credential, str):  # an accepted one was verified, mrss.auth)
            detail["author"] = claimed_user(credential) or "(token)"
    digest = hashlib.sha256(event.topic.encode("utf-8", "replace") + b"\0")
    if event_id:
        digest.update(b"id\0" + event_id.encode("utf-8", "replace"))
    else:
        digest.update(b"payload\0" + event.payload)
    return Identity(digest.hexdigest()[:32], event_id, detail)


class EventIntake:
    """Handles external events in order on one thread; see the module rules."""

    def __init__(self, percept: PerceptPublisher, *, policy: RetryPolicy | None = None,
                 reporter: EventReporter | None = None, log: logging.Logger | None = None,
                 memory: int = DEFAULT_MEMORY,
                 durable: Callable[[Callable[[], object]], object] | None = None) -> None:
        self.percept = percept
        self._durable = durable
        self.counters: EventCounters = percept.counters
        self.policy = policy or RetryPolicy()
        self.log = log or logging.getLogger("mrss.events")
        self.reporter = reporter or EventReporter("events", log=self.log)
        self._memory = memory
        self._seen: OrderedDict[str, None] = OrderedDict()
        self._lock = threading.Lock()
        self._queue: queue.Queue[tuple[InboundEvent, Work, Identity] | None] = queue.Queue()
        self._stopping = threading.Event()
        self._idle = threading.Condition(self._lock)
        self._unfinished = 0
        self._thread: threading.Thread | None = None

    # -- lifecycle -------------------------------------------------------------------
    def start(self) -> None:
        """Start the intake thread (events submitted before wait for it)."""
        if self._thread is None:
            self._thread = threading.Thread(target=self._serve, name="mrss-event-intake",
                                            daemon=True)
            self._thread.start()

    def stop(self, timeout: float = 5.0) -> None:
        """Stop after the event in hand; what is left is not acknowledged (redelivered)."""
        self._stopping.set()
        self._queue.put(None)
        if self._thread is not None and self._thread is not threading.current_thread():
            self._thread.join(timeout)

    def wait_idle(self, timeout: float) -> bool:
        """Wait until every submitted event has an outcome; False on timeout."""
        with self._idle:
            return self._idle.wait_for(lambda: self._unfinished == 0, timeout)

    # -- intake ----------------------------------------------------------------------
    def submit(self, event: InboundEvent, work: Work) -> None:
        """Queue `event`, to be handled by `work()` on the intake thread."""
        with self._lock:
            self.counters.received += 1
        if self.reporter.is_reply_topic(event.topic):
            self._acknowledge(event)  # our own answers, seen through a wildcard
            return
        identity = identify(event)
        with self._lock:
            known = identity.key in self._seen
            if known and (identity.event_id or event.redelivered):
                self.counters.duplicates += 1
                duplicate = True
            else:
                self._remember(identity.key)
                self._unfinished += 1
                duplicate = False
        if duplicate:
            self.reporter.report(EventStatus.DUPLICATE, event.topic,
                                 event_id=identity.event_id, detail=identity.detail)
            self._acknowledge(event)
            return
        self._queue.put((event, work, identity))

    def run_once(self, topic: str, work: Work,
                 batch_id: str | None = None) -> tuple[Attempt, str]:
        """One attempt at `work` for an event on `topic`: how it ended, and why.

        Counts bad payloads (by topic) and handler errors. A handler error is logged
        here; a bad payload is logged by whoever tells of it (`EventReporter`: once per
        topic and kind of reason per interval), never once per message.
        """
        try:
            with self.percept.batch(batch_id):
                work()
            return Attempt.ACCEPTED, ""
        except Exception as exc:
            attempt = classify(exc)
            with self._lock:
                counters = self.counters
                if attempt is Attempt.BAD_INPUT:
                    counters.bad_payloads += 1
                    counters.bad_by_topic[topic] = counters.bad_by_topic.get(topic, 0) + 1
                elif attempt is Attempt.HANDLER_ERROR:
                    counters.handler_errors += 1
                counters.last_error = f"{topic}: {exc.__class__.__name__}: {exc}" \
                    if attempt is not Attempt.BAD_INPUT else f"{topic}: {exc}"
            if attempt is Attempt.HANDLER_ERROR:
                self.log.exception("adapter handler failed on topic %r", topic)
            reason = str(exc) if attempt is Attempt.BAD_INPUT \
                else f"{exc.__class__.__name__}: {exc}"
            return attempt, reason

    # -- the intake thread -----------------------------------------------------------
    def _serve(self) -> None:
        while True:
            item = self._queue.get()
            if item is None or self._stopping.is_set():
                return
            event, work, identity = item
            try:
                self._handle(event, work, identity)
            except Exception:  # never lose the thread to a reporting failure
                self.log.exception("event on %r could not be finished", event.topic)
            finally:
                with self._idle:
                    self._unfinished -= 1
                    self._idle.notify_all()

    def _handle(self, event: InboundEvent, work: Work, identity: Identity) -> None:
        first = time.monotonic()
        attempts = 0
        while True:
            attempts += 1
            attempt, reason = self.run_once(event.topic, work, identity.percept_ids)
            if attempt is not Attempt.UNAVAILABLE:
                break
            wait = self.policy.next_wait(attempts, time.monotonic() - first)
            if wait is None:
                break
            with self._lock:
                self.counters.retries += 1
            if attempts == 1:
                self.log.warning("event on %r waits for a dependency (retrying up to %gs): %s",
                                 event.topic, self.policy.budget, reason)
            if self._stopping.wait(wait):
                self.log.info("event on %r left unacknowledged for the next incarnation",
                              event.topic)
                return
        status = {Attempt.ACCEPTED: EventStatus.ACCEPTED,
                  Attempt.BAD_INPUT: EventStatus.REJECTED}.get(attempt, EventStatus.FAILED)
        if attempt is Attempt.UNAVAILABLE:
            reason = f"dependency unavailable for {time.monotonic() - first:.1f}s " \
                     f"({attempts} attempts): {reason}"
            with self._lock:
                self.counters.failed += 1
        elif attempt is Attempt.HANDLER_ERROR:
            reason = f"handler error: {reason}"
            with self._lock:
                self.counters.failed += 1
        if status is not EventStatus.ACCEPTED:
            with self._lock:
                self._seen.pop(identity.key, None)  # the sender may try this one again
        self.reporter.report(status, event.topic, event_id=identity.event_id, reason=reason,
                             attempts=attempts, detail=identity.detail)
        self._acknowledge(event)

    def _remember(self, key: str) -> None:
        # Caller holds the lock.
        self._seen[key] = None
        self._seen.move_to_end(key)
        while len(self._seen) > self._memory:
            self._seen.popitem(last=False)

    def _acknowledge(self, event: InboundEvent) -> None:
        """Acknowledge `event` once every percept sent so far is durable."""
        if event.acknowledge is None:
            return
        if self._durable is None:
            self._acknowledge_now(event)
        else:
            self._durable(lambda: self._acknowledge_now(event))

    def _acknowledge_now(self, event: InboundEvent) -> None:
        assert event.acknowledge is not None
        try:
            event.acknowledge()
        except Exception as exc:  # the broker will deliver it again
            self.log.warning("event on %r not acknowledged: %r", event.topic, exc)
