"""The one place a dead incarnation's messages are dropped.

Every envelope names its sender (`src`) and the sender's incarnation (`inc`: 1 for a
supervised component's first run, 2 after its first restart, ...; 0 for a sender nobody
supervises, such as `mrss send`). A receiver must never act on what a dead incarnation
said after its successor took over: a late status of a killed RCL, a request of a killed
reasoner still in flight. The rule, applied on every receive path of the bus (the
subscriber and the reliable receiver) before any handler sees a message:

    a message from incarnation i of src is stale once a later incarnation of src is
    known to be live: heard on the bus (any message of src with a higher inc), or
    announced by its supervisor (`sup.start` of child src with that inc).

A stale message is dropped, counted (`dropped`) and logged once per dead incarnation.
Senders with inc 0 are never stale. A component shares one `Incarnations` among its
receivers, and may teach it what it knew before a restart of its own (`learn`: the RCL
seeds it from its journal). Receivers whose purpose is to see everything (a recording,
the chaos history, the dashboard) opt out with `Stale.KEEP`.
"""

from __future__ import annotations

import enum
import logging
import threading

from mrss.messages import Envelope, SupEvent

log = logging.getLogger("mrss.bus")

# The supervisor's announcement of a new incarnation (mrss.supervision.events.START).
ANNOUNCEMENT = "sup.start"


class Stale(enum.Enum):
    """What a receiver does with a dead incarnation's messages."""

    DROP = "drop"  # every component: act only on live incarnations
    KEEP = "keep"  # observers: recordings, the chaos history


class Incarnations:
    """The live incarnation of each sender, as one receiver has learnt it."""

    def __init__(self, where: str) -> None:
        self.where = where
        self.dropped = 0
        self._live: dict[str, int] = {}
        self._logged: set[tuple[str, int]] = set()
        self._lock = threading.Lock()  # shared by a component's receiving threads

    def live(self, src: str) -> int:
        """The newest incarnation of `src` known to be live (0: none known)."""
        return self._live.get(src, 0)

    def admit(self, env: Envelope) -> bool:
        """Whether `env` comes from a live incarnation (and learn from it)."""
        body = env.body
        if isinstance(body, SupEvent) and env.topic == ANNOUNCEMENT:
            announced = body.detail.get("inc")
            if isinstance(announced, int) and not isinstance(announced, bool):
                self.learn(body.child, announced)
        if env.inc <= 0 or env.inc == self._live.get(env.src):
            return True  # unsupervised, or the live incarnation: the common case, no lock
        with self._lock:
            live = self._live.get(env.src, 0)
            if env.inc >= live:
                self._live[env.src] = env.inc
                return True
            self.dropped += 1
            first = (env.src, env.inc) not in self._logged
            if first:
                if len(self._logged) >= 1024:  # bounded: start over
                    self._logged.clear()
                self._logged.add((env.src, env.inc))
        if first:
            log.info("%s: dropping messages of %s incarnation %d (incarnation %d is live), "
                     "the first on %s", self.where, env.src, env.inc, live, env.topic)
        return False

    def learn(self, src: str, inc: int) -> None:
        """`src` runs as incarnation `inc` (or a later one): older ones are dead."""
        with self._lock:
            if inc > self._live.get(src, 0):
                self._live[src] = inc
