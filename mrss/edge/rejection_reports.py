"""A component's refusal counters on the bus, for the dashboard.

Every component process runs a `RejectionReporter` beside its heartbeat
(`mrss.runtime.main`): when the refusals counted in the process
(`mrss.edge.rejections.process_counts`: robot data, telemetry records, percepts,
events, MAVLink messages) have changed, it publishes a `Rejections` message on
`edge.rejections.<component>` with the total and the `MAX_KINDS` commonest kinds, at
most once every `REPORT_EVERY` seconds, and the same again every `REPEAT_EVERY` seconds
(for a dashboard that attached later); nothing while nothing is refused. The counts
are since the process (this incarnation) started. Each tick also ends the log intervals
that are over (`roll_all`), so held-back refusals are summarised in time.
"""

from __future__ import annotations

import time
from collections import Counter
from collections.abc import Callable

from mrss.edge.rejections import process_counts, roll_all
from mrss.messages import Message, Rejections

REPORT_EVERY = 2.0  # seconds between two reports of one component, at least
REPEAT_EVERY = 10.0  # seconds after which unchanged counters are reported again
MAX_KINDS = 20  # kinds of refusal named in one report (the commonest)


class RejectionReporter:
    """Publishes a component's `Rejections` when its counters moved (module docstring)."""

    def __init__(self, component: str, publish: Callable[[Message], object], *,
                 every: float = REPORT_EVERY, repeat: float = REPEAT_EVERY,
                 counts: Callable[[], dict[str, int]] = process_counts,
                 clock: Callable[[], float] = time.monotonic) -> None:
        self.component = component
        self.publish = publish
        self.every = every
        self.repeat = repeat
        self.counts = counts
        self.clock = clock
        self.sent = 0  # the total last reported
        self._next = 0.0
        self._last = 0.0

    def tick(self) -> Rejections | None:
        """Publish the counters if they moved and the last report is old enough; the
        report sent, or None."""
        roll_all()
        now = self.clock()
        if now < self._next:
            return None
        counts = self.counts()
        total = sum(counts.values())
        if total == self.sent and (total == 0 or now - self._last < self.repeat):
            return None
        report = Rejections(component=self.component, total=total,
                            counts=dict(Counter(counts).most_common(MAX_KINDS)))
        self.publish(report)
        self.sent = total
        self._next = now + self.every
        self._last = now
        return report
