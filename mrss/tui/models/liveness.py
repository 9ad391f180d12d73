"""Whether the picture on screen is current: the staleness banner's model (no Textual).

The dashboard notes when it last heard anything from the system (any bus message not
its own). The banner is empty while that is recent; otherwise it says what is wrong,
most serious first: the system ended ("system stopped (exit 0)", "wildfire gave up:
rcl: ..."), the bus proxy is not reachable, or nothing came for `stale_after` seconds
("no heartbeat for 12 s"). Once the system has ended the banner keeps saying so: the
final picture stays for the operator to read.
"""

from __future__ import annotations

import time
from collections.abc import Callable


class Liveness:
    """Last time the system was heard from, and how it ended if it did."""

    def __init__(self, stale_after: float = 5.0,
                 clock: Callable[[], float] = time.monotonic) -> None:
        self.stale_after = stale_after
        self._clock = clock
        self.started = clock()
        self.last_heard: float | None = None
        self.ended = ""  # why the system is gone, once it is

    def heard(self) -> None:
        self.last_heard = self._clock()

    def end(self, why: str) -> None:
        """The system is gone (stopped, gave up); the first reason given is kept."""
        if not self.ended:
            self.ended = why

    def silence(self) -> float:
        """Seconds since the system was last heard from (or since the dashboard started)."""
        return self._clock() - (self.last_heard if self.last_heard is not None
                                else self.started)

    def banner(self, connected: bool) -> str:
        """What is wrong with the picture, or "" if it is current."""
        if self.ended:
            return self.ended
        if not connected:
            return "waiting for the bus proxy"
        quiet = self.silence()
        if quiet < self.stale_after:
            return ""
        if self.last_heard is None:
            return f"nothing heard from the system in {quiet:.0f} s"
        return f"no heartbeat for {quiet:.0f} s: the picture may be out of date"
