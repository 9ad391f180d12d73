"""The one place a message is refused for who sent it: a dead, unproven or replayed sender.

Every envelope names its sender (`src`) and the sender's incarnation (`inc`: 1 for a
supervised component's first run, 2 after its first restart, ...; 0 for a sender nobody
supervises, such as `mrss send`). Incarnations come only from the root supervisor that
started the process: on a bus with the run's incarnation key (mrss/messages/
credentials.py) each envelope of incarnation i > 0 carries `cred`, the supervisor's
proof of (src, i). The rule, applied on every receive path of the bus (the subscriber
and the reliable receiver) before any handler sees a message:

    a message is refused when it was replayed (`replayed`, set by `mrss replay`), when
    it claims an incarnation i > 0 of src that its credential does not prove, or when a
    later incarnation of src is known to be live: proven on the bus (a message of src
    with a higher inc), or announced by its supervisor (`sup.start` of child src with
    that inc and its credential). Only a proven incarnation ever raises the bar; an
    unsupervised sender's `sup.start` that does not prove its claim is refused.

Senders with inc 0 are never stale and prove nothing (they never raise the bar either).
On a bus without a key (a library user's own, the tests' in-process buses) nothing can
be proven: every claimed incarnation is believed, as before the key existed.

A refusal is counted per (src, reason) (`refused`, `refusal_counts`: the component's
`Rejections` report on the bus, which the dashboard shows), and logged once per (src,
reason) and interval. A component shares one `Incarnations` among its receivers, and
may teach it what it knew before a restart of its own (`learn`: the RCL seeds it from
its journal). Receivers whose purpose is to see everything (a recording, the chaos
history, the dashboard) opt out with `Stale.KEEP`; they see `env.replayed`.
"""

from __future__ import annotations

import enum
import logging
import threading
import time
import weakref
from collections import Counter

from mrss.messages import Envelope, IncarnationKey, SupEvent

log = logging.getLogger("mrss.bus")

# The supervisor's announcement of a new incarnation (mrss.supervision.events.START).
ANNOUNCEMENT = "sup.start"
LOG_INTERVAL = 60.0  # seconds between two log lines of one (src, reason)
MAX_COUNTED = 256  # (src, reason) pairs counted apart; the others together
OTHER_SENDERS = "(other senders)"


class Stale(enum.Enum):
    """What a receiver does with messages the rule refuses."""

    DROP = "drop"  # every component: act only on live, proven, not replayed senders
    KEEP = "keep"  # observers: recordings, the chaos history, the dashboard


class Refusal(enum.Enum):
    """Why the rule refused a message (the reason counted and reported)."""

    STALE = "a dead incarnation"
    UNPROVEN = "an incarnation its supervisor did not start"
    REPLAYED = "replayed, not live"


_filters: weakref.WeakSet[Incarnations] = weakref.WeakSet()
_filters_lock = threading.Lock()


def refusal_counts() -> dict[str, int]:
    """Every live filter's refusals in this process, as "bus message from <src>:
    <reason>" -> count (the form of `mrss.edge.rejections.process_counts`)."""
    with _filters_lock:
        filters = list(_filters)
    total: Counter[str] = Counter()
    for live in filters:
        total.update(live.rejection_counts())
    return dict(total)


class Incarnations:
    """The live incarnation of each sender, as one receiver has learnt it."""

    def __init__(self, where: str, key: IncarnationKey | None = None) -> None:
        self.where = where
        self.key = key
        self.dropped = 0  # refusals of every reason
        self.refused: Counter[tuple[str, Refusal]] = Counter()
        self._live: dict[str, int] = {}
        # The fast path: src -> (inc, cred) of its live incarnation, proven once.
        self._known: dict[str, tuple[int, bytes]] = {}
        self._logged: dict[tuple[str, Refusal], float] = {}
        self._lock = threading.Lock()  # shared by a component's receiving threads
        with _filters_lock:
            _filters.add(self)

    def adopt(self, key: IncarnationKey | None) -> None:
        """Check incarnations with `key` (the bus's) from now on, if it had none."""
        if key is not None and self.key is None:
            with self._lock:
                self.key = key
                self._known.clear()  # believed without proof: to be proven again

    def live(self, src: str) -> int:
        """The newest incarnation of `src` known to be live (0: none known)."""
        return self._live.get(src, 0)

    def admit(self, env: Envelope) -> bool:
        """Whether the rule lets `env` through (and learn from it when proven)."""
        if env.replayed:
            return self.refuse(env, Refusal.REPLAYED, "")
        body = env.body
        if isinstance(body, SupEvent) and env.topic == ANNOUNCEMENT and \
                not self._announced(body) and env.inc <= 0:
            return self.refuse(env, Refusal.UNPROVEN, f"a start of {body.child[:40]} "
                                "that its supervisor did not announce")
        if env.inc <= 0 or self._known.get(env.src) == (env.inc, env.cred):
            return True  # unsupervised, or the live incarnation as proven: no lock
        key = self.key
        if key is not None and not key.vouches(env.src, env.inc, env.cred):
            return self.refuse(env, Refusal.UNPROVEN, f"inc {env.inc}, "
                                f"{'a wrong' if env.cred else 'no'} credential")
        with self._lock:
            live = self._live.get(env.src, 0)
            if env.inc >= live:
                self._live[env.src] = env.inc
                self._known[env.src] = (env.inc, env.cred)
                return True
        return self.refuse(env, Refusal.STALE, f"inc {env.inc}; {live} is live")

    def _announced(self, event: SupEvent) -> bool:
        """A `sup.start`: learn from it as far as its credential proves it. False for a
        claim it does not prove (it teaches nothing; from an unsupervised sender, such
        as a forged root, it is refused; an actor supervisor inside a component
        announces its actors without one)."""
        inc, cred = event.detail.get("inc"), event.detail.get("cred", "")
        if not isinstance(inc, int) or isinstance(inc, bool):
            return True  # no incarnation claimed
        if self.key is not None:
            try:
                proven = isinstance(cred, str) and self.key.vouches(
                    event.child, inc, bytes.fromhex(cred))
            except ValueError:
                proven = False
            if not proven:
                return False
        self.learn(event.child, inc)
        return True

    def learn(self, src: str, inc: int) -> None:
        """`src` runs as incarnation `inc` (or a later one): older ones are dead."""
        with self._lock:
            if inc > self._live.get(src, 0):
                self._live[src] = inc
                self._known.pop(src, None)

    def refuse(self, env: Envelope, reason: Refusal, detail: str) -> bool:
        """Count (and now and then log) one refusal; False. (Also the mesh's border's,
        mrss/bus/border.py, for what a peer node cannot prove.)"""
        key = (env.src[:64], reason)
        now = time.monotonic()
        with self._lock:
            if key not in self.refused and len(self.refused) >= MAX_COUNTED:
                key = (OTHER_SENDERS, reason)  # bounded: a flood of made-up names
            self.dropped += 1
            self.refused[key] += 1
            count = self.refused[key]
            last = self._logged.get(key)
            due = last is None or now - last >= LOG_INTERVAL
            if due:
                if len(self._logged) >= 1024:  # bounded: start over
                    self._logged.clear()
                self._logged[key] = now
        if due:
            level = logging.INFO if reason is Refusal.STALE else logging.WARNING
            log.log(level, "%s: refused a message of %s: %s (%s), on %s; %d so far (one "
                    "line per %gs)", self.where, key[0], reason.value, detail, env.topic,
                    count, LOG_INTERVAL)
        return False

    def rejection_counts(self) -> dict[str, int]:
        """Refusals since start, as "bus message from <src>: <reason>" -> count."""
        with self._lock:
            return {f"bus message from {src}: {reason.value}": n
                    for (src, reason), n in self.refused.items()}
