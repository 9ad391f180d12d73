"""Counting and logging what was refused, without flooding the log.

A refused record is counted by (source, reason) — source: the robot or sender, reason:
`mrss.edge.validation.Rejected.reason`. The first refusal of a (source, reason) in an
interval is logged with its detail; the others in that interval are only counted, and
once the interval is over the next refusal, `roll` (which the component's reporter calls
every tick, `roll_all`) or `flush` logs one summary line of what was held back. No
traceback is ever logged for bad data. The work stays bounded however the refusals
vary: at most `MAX_LOGGED_KINDS` first lines per interval (the other kinds go to the
summary), and at most `MAX_COUNTED_KINDS` kinds counted apart (the rest as one,
`OTHER`).

A library that logs each refusal itself (amqtt: an ERROR and a WARNING per bare TCP
connection) is brought under the same rule by a `LoggedRefusals` filter on its logger:
the records it recognises become counted refusals of a `RejectionLog` instead.

Every `RejectionLog` (and every other refusal counter that calls `register`, like the
MAVLink signing checks) is known to its process: `process_counts()` adds them up for
the component's periodic `Rejections` message on the bus (`mrss.edge.rejection_reports`),
which the dashboard shows.
"""

from __future__ import annotations

import logging
import re
import threading
import time
import weakref
from collections import Counter
from collections.abc import Callable, Sequence
from typing import Protocol

DEFAULT_INTERVAL = 60.0
MAX_LOGGED_KINDS = 10  # first lines of one interval; other kinds are summarised
MAX_COUNTED_KINDS = 1000  # (source, reason) pairs counted apart; more count as OTHER
OTHER = ("*", "other kinds")


class Counted(Protocol):
    """A refusal counter the process reports: "<what> from <source>: <reason>" -> count."""

    def rejection_counts(self) -> dict[str, int]: ...


_counters: weakref.WeakSet[Counted] = weakref.WeakSet()
_counters_lock = threading.Lock()


def register(counter: Counted) -> None:
    """Count `counter`'s refusals in `process_counts` while it lives."""
    with _counters_lock:
        _counters.add(counter)


def roll_all() -> None:
    """`roll` every RejectionLog of the process: summaries of intervals that are over."""
    with _counters_lock:
        counters = list(_counters)
    for counter in counters:
        if isinstance(counter, RejectionLog):
            counter.roll()


def process_counts() -> dict[str, int]:
    """The refusals of every registered counter alive in this process, added up."""
    with _counters_lock:
        counters = list(_counters)
    total: Counter[str] = Counter()
    for counter in counters:
        total.update(counter.rejection_counts())
    return dict(total)


class RejectionLog:
    """Counters and rate-limited warnings of refused input (thread-safe)."""

    def __init__(self, log: logging.Logger, what: str = "record", *,
                 interval: float = DEFAULT_INTERVAL,
                 clock: Callable[[], float] = time.monotonic) -> None:
        self.log = log
        self.what = what
        self.interval = interval
        self.clock = clock
        self.counts: Counter[tuple[str, str]] = Counter()  # since start
        self._held: Counter[tuple[str, str]] = Counter()  # not logged yet
        self._logged: set[tuple[str, str]] = set()  # logged in this interval
        self._since = clock()
        self._lock = threading.Lock()
        register(self)

    @property
    def total(self) -> int:
        """Refusals since start."""
        with self._lock:
            return sum(self.counts.values())

    def reject(self, source: str, reason: str, detail: str = "") -> None:
        """Count one refusal; log it unless that (source, reason) was logged this interval."""
        if not self.seen(source, reason):
            self.log.warning("refused %s from %s: %s%s (more like it are counted, "
                             "summarised every %gs)", self.what, source[:64], reason[:120],
                             f" ({detail[:200]})" if detail else "", self.interval)

    def seen(self, source: str, reason: str) -> bool:
        """Count one refusal the caller logs itself when this returns False (the first of
        its (source, reason) this interval); True: held back, summarised later."""
        key = (source[:64], reason[:120])
        with self._lock:
            if key not in self.counts and len(self.counts) >= MAX_COUNTED_KINDS:
                key = OTHER
            self.counts[key] += 1
            summary = self._roll()
            held = key in self._logged or len(self._logged) >= MAX_LOGGED_KINDS
            if held:
                self._held[key] += 1
            else:
                self._logged.add(key)
        if summary:
            self.log.warning("%s", summary)
        return held

    def roll(self) -> None:
        """If the interval is over, log the summary of what it held back (if anything)
        and start the next one; a quiet source's last refusals are summarised in time."""
        with self._lock:
            summary = self._roll()
        if summary:
            self.log.warning("%s", summary)

    def flush(self) -> None:
        """Log the summary of refusals held back so far (e.g. when stopping)."""
        with self._lock:
            summary = self._summary()
            self._held.clear()
        if summary:
            self.log.warning("%s", summary)

    def stats(self) -> dict[str, int]:
        """Refusals since start, as "source: reason" -> count (for stats and dashboards)."""
        with self._lock:
            return {f"{source}: {reason}": n for (source, reason), n in self.counts.items()}

    def rejection_counts(self) -> dict[str, int]:
        """Refusals since start, as "<what> from <source>: <reason>" -> count."""
        with self._lock:
            return {f"{self.what} from {source}: {reason}": n
                    for (source, reason), n in self.counts.items()}

    def _roll(self) -> str:
        now = self.clock()
        if now - self._since < self.interval:
            return ""
        summary = self._summary()
        self._since = now
        self._held.clear()
        self._logged.clear()
        return summary

    def _summary(self) -> str:
        if not self._held:
            return ""
        parts = ", ".join(f"{source}: {reason} x{n}"
                          for (source, reason), n in self._held.most_common(10))
        more = len(self._held) - 10
        return (f"refused {sum(self._held.values())} more {self.what}(s) "
                f"(total {sum(self.counts.values())}): {parts}"
                + (f" and {more} more kinds" if more > 0 else ""))


class LoggedRefusals(logging.Filter):
    """A filter for a library's logger: its records that tell of a refusal are counted in
    `rejections` (and logged by it, once per source and reason per interval) instead.

    `kinds`: (pattern, reason); a record whose message the pattern matches is one refusal
    of that reason, its source the pattern's `source` group ("-" without one). `echoes`:
    patterns of records that only repeat a refusal already counted (dropped, not counted).
    Every other record passes unchanged.
    """

    def __init__(self, rejections: RejectionLog, kinds: Sequence[tuple[re.Pattern[str], str]],
                 echoes: Sequence[re.Pattern[str]] = ()) -> None:
        super().__init__()
        self.rejections = rejections
        self.kinds = tuple(kinds)
        self.echoes = tuple(echoes)

    def filter(self, record: logging.LogRecord) -> bool:
        message = record.getMessage()
        for pattern, reason in self.kinds:
            match = pattern.search(message)
            if match is not None:
                source = match.group("source") if "source" in pattern.groupindex else "-"
                self.rejections.reject(source, reason, message)
                return False
        return not any(pattern.search(message) for pattern in self.echoes)
