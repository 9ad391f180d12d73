"""The root's supervision events, held while the bus proxy is down and delivered after.

The bus proxy is one of the root's own children, so the events about its restarts (its
exit, the restart, its next start; a give-up) are emitted exactly when nobody can hear
them. ZeroMQ would hand them to the new proxy as soon as the root's publisher
reconnects, which is usually before any subscriber has, and a proxy drops what nobody
has subscribed to. So `EventOutbox`, the root's publish callable, applies two rules:

1. From the `exit` of the bus child until it is back, every event is held, in order, at
   most `limit` of them (the oldest are dropped beyond that, and the count is logged).
2. The proxy is back when the bus child has reported ready and a subscription to every
   `sup.` event (a prefix of it; `""` excluded: that is the proxy taking everything) has
   come through it to the root's publisher; `settle` seconds later (so that other
   subscribers reconnecting at about the same time are in too) the held events go out
   in order. If no such subscriber comes within `max_wait`, they go out anyway.

`watch` returns the subscriptions seen since the last call (`Publisher.subscriptions`
of a publisher made with `watch_subscriptions=True`). The proxy forwards only the first
subscriber of a topic, so a second subscriber that reconnects later than `settle` after
the first may still miss the held events; `ctl.tree` gives it the current state.
"""

from __future__ import annotations

import logging
import threading
import time
from collections import deque
from collections.abc import Callable, Iterable

from mrss.messages import Message, SupEvent
from mrss.supervision import events as ev

log = logging.getLogger("mrss.supervision.outbox")

SUP_PREFIX = "sup."
POLL = 0.01  # seconds between looks at the subscriptions while waiting for the proxy


def covers_sup_events(prefix: str) -> bool:
    """Whether a subscriber with this topic prefix hears every supervision event."""
    return bool(prefix) and SUP_PREFIX.startswith(prefix)


class EventOutbox:
    """A publish callable for the root that holds events across a bus proxy restart."""

    def __init__(
        self, publish: Callable[[Message], object], bus_child: str,
        watch: Callable[[], Iterable[str]], *, limit: int = 1000, settle: float = 0.3,
        max_wait: float = 10.0,
    ) -> None:
        self._publish = publish
        self.bus_child = bus_child
        self._watch = watch
        self.limit = limit
        self.settle = settle
        self.max_wait = max_wait
        self._lock = threading.Lock()
        self._held: deque[Message] = deque()
        self._holding = False
        self._dropped = 0
        self._generation = 0  # which proxy incarnation a waiting thread waits for
        self._seen: list[str] = []  # subscriptions seen since the proxy's last exit
        self._closed = False

    @property
    def holding(self) -> bool:
        return self._holding

    def __call__(self, msg: Message) -> None:
        event = msg.event if isinstance(msg, SupEvent) and msg.child == self.bus_child \
            and "/" not in msg.supervisor else ""
        with self._lock:
            if event == ev.EXIT:
                self._holding = True
                self._generation += 1
                self._forget_subscriptions()  # the dead proxy's: they say nothing now
            if self._holding:
                self._hold(msg)
                if event == ev.START:
                    self._generation += 1
                    threading.Thread(target=self._wait_for_proxy, args=(self._generation,),
                                     name="mrss-sup-outbox", daemon=True).start()
                return
        self._publish(msg)

    def _forget_subscriptions(self) -> None:
        # Caller holds the lock. What came through the dead proxy says nothing now.
        self._seen.clear()
        try:
            self._watch()
        except Exception:  # the publisher closed: nothing to forget
            pass

    def _hold(self, msg: Message) -> None:
        # Caller holds the lock.
        if len(self._held) >= self.limit:
            self._held.popleft()
            self._dropped += 1
        self._held.append(msg)

    def _wait_for_proxy(self, generation: int) -> None:
        """Rule 2: wait for a `sup.` subscriber through the new proxy, then deliver."""
        deadline = time.monotonic() + self.max_wait
        joined: float | None = None
        while not self._closed:
            now = time.monotonic()
            with self._lock:  # so that no exit comes between the look and the check
                if generation != self._generation:
                    return  # the proxy went down again: a newer waiter takes over
                try:
                    self._seen.extend(self._watch())
                except Exception:  # the publisher closed: nothing more to deliver
                    return
                if joined is None and any(covers_sup_events(t) for t in self._seen):
                    joined = now
            if (joined is not None and now >= joined + self.settle) or now >= deadline:
                if joined is None:
                    log.warning("no subscriber of sup.* events joined the restarted bus "
                                "proxy within %gs; delivering the held events anyway",
                                self.max_wait)
                self.flush(generation)
                return
            time.sleep(POLL)

    def flush(self, generation: int | None = None) -> None:
        """Deliver what is held, in order (for `generation`'s proxy, if given)."""
        with self._lock:
            if generation is not None and generation != self._generation:
                return  # the proxy went down again meanwhile: keep holding
            held, self._held = list(self._held), deque()
            dropped, self._dropped = self._dropped, 0
            self._holding = False
            for msg in held:  # under the lock: later events must not overtake these
                try:
                    self._publish(msg)
                except Exception:  # a broken bus must not break supervision
                    log.exception("cannot publish a held supervision event")
        if dropped:
            log.warning("dropped %d supervision event(s) while the bus proxy was down "
                        "(at most %d are held)", dropped, self.limit)

    def close(self) -> None:
        """Deliver what is held (best effort: the proxy may be gone) and stop waiting."""
        self._closed = True
        self.flush()
