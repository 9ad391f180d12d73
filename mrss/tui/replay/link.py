"""The dashboard's link in a replay: messages come from the recording, nothing goes out.

`ReplayLink` stands where `BusLink` stands in a live dashboard (the app's seam between
the bus and its intake): the player `feed`s it the recorded messages whose time has
come, it wakes the app as the bus link does, and the app drains them into the same
intake. A recording has no system to ask: what the dashboard would publish (snapshot
and mind requests, world model queries) is dropped and counted in `unsent`; the
operator's commands are refused before they get here (a replay is read-only).
"""

from __future__ import annotations

from collections.abc import Callable

from mrss.bus import BusEndpoints
from mrss.messages import Envelope, Message
from mrss.tui.buslink import BusLink

# A replay has no bus: these are never connected to (the app's parts take endpoints).
NO_BUS = BusEndpoints("tcp://127.0.0.1:9", "tcp://127.0.0.1:10")


class ReplayLink(BusLink):
    """A `BusLink` fed from a recording; `where` names it in the header."""

    def __init__(self, where: str) -> None:
        super().__init__(NO_BUS)
        self._where = where
        self.unsent = 0  # requests the dashboard made, that no system could answer

    def start(self, wake: Callable[[], object]) -> None:
        self._wake = wake

    def poll(self) -> None:
        """Nothing to take from a socket: the player feeds the inbox."""

    def feed(self, envelopes: list[Envelope]) -> None:
        """Recorded messages whose time has come; the app is woken to drain them."""
        if not envelopes:
            return
        self.received += len(envelopes)
        self._inbox.extend(envelopes)
        if not self._woken:
            self._woken = True
            self._wake()

    def discard(self) -> None:
        """Forget what was fed and not drained yet (a seek rebuilds from the recording)."""
        self.drain()

    @property
    def connected(self) -> bool:
        return True

    @property
    def welcomes(self) -> int:
        return 1

    def publish(self, msg: Message, topic: str | None = None) -> str:
        self.unsent += 1
        return ""

    def close(self) -> None:
        self._inbox.clear()

    def where(self) -> str:
        return self._where
