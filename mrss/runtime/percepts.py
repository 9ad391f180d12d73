"""Publishing percepts: literal strings (checked) or functor + args (built safely).

`PerceptPublisher` is what an adapter calls. Inside a guarded handler the percepts are
held back and published only when the handler returns normally, so a payload that
fails half-way through never turns into a percept. A batch may name the event it
belongs to (`batch(event_id)`): its percepts then get the message ids
`<event_id>.0`, `<event_id>.1`, ..., the same however often the event is delivered.

The sink is `sink(percept, msg_id)` (`msg_id` None: the sink picks one); in a component
it is `mrss.runtime.percept_channel.PerceptChannel.send`.
"""

from __future__ import annotations

import threading
from collections.abc import Callable, Iterator, Sequence
from contextlib import contextmanager
from dataclasses import dataclass, field

from mrss.agentspeak.literals import Term, check_literal, literal
from mrss.messages import Percept

PerceptSink = Callable[[Percept, str | None], object]


@dataclass
class EventCounters:
    """What an events manager has seen: messages, percepts, and rejected input by topic."""

    received: int = 0
    percepts: int = 0
    bad_payloads: int = 0
    handler_errors: int = 0
    retries: int = 0  # attempts repeated because a dependency was down
    failed: int = 0  # events given up on after the retry budget
    duplicates: int = 0  # redelivered events recognised and not handled again
    bad_by_topic: dict[str, int] = field(default_factory=dict)
    last_error: str = ""

    def snapshot(self) -> dict[str, object]:
        """A plain copy for logs, the TUI and tests."""
        return {"received": self.received, "percepts": self.percepts,
                "bad_payloads": self.bad_payloads, "handler_errors": self.handler_errors,
                "retries": self.retries, "failed": self.failed,
                "duplicates": self.duplicates,
                "bad_by_topic": dict(self.bad_by_topic), "last_error": self.last_error}


class PerceptPublisher:
    """Callable that publishes `Percept`s on the bus through `sink`.

        publish("area_goal_received(a1, 3)")              # a whole literal, validated
        publish("area_goal_received", Atom("a1"), 3)     # functor and args, quoted safely
        publish("area_goal_received", Atom("a1"), 3, op="remove")
    """

    def __init__(self, sink: PerceptSink, counters: EventCounters | None = None) -> None:
        self._sink = sink
        self.counters = counters or EventCounters()
        self._local = threading.local()
        self._lock = threading.Lock()

    def __call__(self, text: str, *args: Term, op: str = "add",
                 annotations: Sequence[Term] = ()) -> str:
        """Publish one percept (held back inside `batch()`); return its literal text."""
        if op not in ("add", "remove"):
            raise ValueError(f"percept op must be 'add' or 'remove', not {op!r}")
        if args or annotations:
            text = literal(text, *args, annotations=annotations)
        else:
            text = check_literal(text)
        percept = Percept(literal=text, op=op)
        held: list[Percept] | None = getattr(self._local, "held", None)
        if held is not None:
            held.append(percept)
        else:
            self._emit(percept, None)
        return text

    @contextmanager
    def batch(self, event_id: str | None = None) -> Iterator[None]:
        """Hold this thread's percepts until the block ends normally; drop them on error.

        With `event_id`, the percepts get the ids `<event_id>.<n>` in order.
        """
        if getattr(self._local, "held", None) is not None:
            yield  # nested: the outer batch decides
            return
        self._local.held = []
        try:
            yield
            held: list[Percept] = self._local.held
        finally:
            self._local.held = None
        for n, percept in enumerate(held):
            self._emit(percept, None if event_id is None else f"{event_id}.{n}")

    def _emit(self, percept: Percept, msg_id: str | None) -> None:
        self._sink(percept, msg_id)
        with self._lock:
            self.counters.percepts += 1
