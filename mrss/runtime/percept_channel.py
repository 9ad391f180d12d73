"""How percepts leave the edge: the reliable channel "percept", and a copy for viewers.

The events manager, the data layer and the world model send every `Percept` through one
`PerceptChannel`:

1. on the reliable channel named "percept" (`mrss.bus.ReliableSender`), which repeats it
   until a `ReliableReceiver` on that channel (the reasoner) acknowledges it, so a
   percept sent while the bus proxy or the reasoner is down arrives once they are back;
2. on the plain `percept` topic, for dashboards, recorders and tests that only watch.

Both copies carry the same envelope id (and the sender's name and incarnation), so a
consumer that hears both handles one: the reliable copy is the one that counts, the
plain one can be dropped by id. An edge event with an identity of its own gives its
percepts ids derived from it (see `mrss.actors.events.intake`), so a redelivered event's percepts
repeat the first delivery's ids.

The reasoner acknowledges a percept only once its percept ledger holds it (on disk),
so an acknowledged percept is durable. The channel keeps its messages in memory only:
what is not acknowledged when the component stops is given up (the sender logs how
many). So whoever must not lose a percept holds on to its own copy of the input until
`when_durable` calls back: the events manager acknowledges an MQTT message to its
broker only then, and the broker delivers it again to the next incarnation otherwise.
"""

from __future__ import annotations

from collections.abc import Callable
from typing import Any, Protocol

from mrss.bus import BusEndpoints, ReliableSender
from mrss.messages import IdGenerator, Percept, encode

CHANNEL = "percept"


class FramePublisher(Protocol):
    """Sends encoded frames on the plain bus (`mrss.bus.Publisher` is one)."""

    def send_frames(self, frames: tuple[bytes, ...] | list[bytes]) -> None: ...


class PerceptChannel:
    """Sends percepts reliably to the reasoner and publishes a copy; thread-safe."""

    def __init__(self, endpoints: BusEndpoints, *, src: str, inc: int,
                 publisher: FramePublisher, reliable: ReliableSender | None = None) -> None:
        self.src, self.inc = src, inc
        self._cred = endpoints.credential(src, inc)
        self._publisher = publisher
        self._ids = IdGenerator()
        self._reliable = reliable or ReliableSender(endpoints, src=src, inc=inc,
                                                    channel=CHANNEL)

    @classmethod
    def for_component(cls, ctx: Any) -> PerceptChannel:
        """The channel of a component, from its `ComponentContext`."""
        return cls(BusEndpoints.from_dict(ctx.bus), src=ctx.name, inc=ctx.incarnation,
                   publisher=ctx.publisher)

    def send(self, percept: Percept, msg_id: str | None = None) -> str:
        """Send `percept` on both paths under one envelope id (new unless given); return it."""
        msg_id = msg_id or self._ids()
        self._reliable.send(percept, msg_id=msg_id)
        self._publisher.send_frames(encode(percept, src=self.src, inc=self.inc,
                                           msg_id=msg_id, cred=self._cred))
        return msg_id

    def when_durable(self, callback: Callable[[], object]) -> None:
        """Call `callback()` once every percept sent so far is in the reasoner's ledger
        (acknowledged): now if none is pending, else on the channel's thread, in order;
        never if the channel closes first."""
        self._reliable.when_acked(callback)

    def pending(self) -> int:
        """How many percepts the reasoner has not acknowledged yet."""
        return self._reliable.pending()

    def flush(self, timeout: float | None = None) -> bool:
        """Wait until every percept is acknowledged; False if `timeout` passes first."""
        return self._reliable.flush(timeout)

    def close(self) -> None:
        """Stop repeating (unacknowledged percepts are given up and counted in the log)."""
        self._reliable.close()
