"""What a replay needs to seek at once: keyframes of the dashboard's models, the events
on the timeline, and the log lines.

Built by one pass over the tape through a shadow of the dashboard's intake (the same
`BusIntake.take` the live dashboard applies bus messages with, on a copy of its models
as they were before anything came): every `KEYFRAME_EVERY` messages the models' state
is copied (`Keyframe`); each message that ends an action failed, restarts a component,
or raises an alert is a `Mark`; each log line is kept with the message it came from.
Seeking to any moment is then restoring the keyframe before it and applying at most
`KEYFRAME_EVERY` messages, whatever the length of the recording (`mrss bench replay`).

A keyframe is the models' attributes pickled (a deep copy by pickle: some 30 times
faster than `copy.deepcopy` for the robots' telemetry series). The topics of the
Messages screen are not kept: a seek counts them again from the last `TOPICS_WINDOW`
messages before the cursor (their latest messages and rates: topics quieter than
that show up at the next message).
"""

from __future__ import annotations

import copy
import copyreg
import dataclasses
import io
import itertools
import pickle
from bisect import bisect_right
from collections.abc import Sequence
from dataclasses import dataclass, field
from enum import StrEnum

from mrss.messages import ActionState, ActionStatus, SupEvent, SupEventKind
from mrss.tui.intake import BusIntake, Mind, Models
from mrss.tui.models.logfilter import LogEntry
from mrss.tui.replay.tape import Frame

KEYFRAME_EVERY = 500  # messages between two keyframes: the most a seek re-applies
TOPICS_WINDOW = 500  # messages a seek counts the Messages screen's topics from
# The models a keyframe keeps (liveness is the dashboard's wall clock; topics: above).
KEPT = ("actions", "robots", "supervision", "goals", "alerts", "map_model")
# Counters (the models' sequence numbers) pickled by their next value.
_PICKLING = copyreg.dispatch_table.copy()
_PICKLING[itertools.count] = lambda c: (itertools.count, (int(repr(c)[6:-1]),))


class MarkKind(StrEnum):
    """The events a replay can seek to, as the timeline bar shows them."""

    ACTION_FAILED = "action failed"
    RESTART = "restart"
    ALERT = "alert"


@dataclass(frozen=True)
class Mark:
    """An event on the timeline: the message (by its index on the tape) that made it."""

    kind: MarkKind
    t: float
    index: int
    text: str


@dataclass
class Keyframe:
    """The models' state once the first `index` messages of the tape were applied."""

    index: int
    state: bytes  # `capture`'s
    mind: Mind | None


def capture(models: Models) -> bytes:
    """The kept models' attributes, pickled."""
    out = io.BytesIO()
    pickler = pickle.Pickler(out, protocol=pickle.HIGHEST_PROTOCOL)
    pickler.dispatch_table = _PICKLING
    pickler.dump({name: vars(getattr(models, name)) for name in KEPT})
    return out.getvalue()


def restore(models: Models, state: bytes) -> None:
    """Put a captured state back into `models`, in place: the widgets keep their models."""
    for name, kept in pickle.loads(state).items():
        attributes = vars(getattr(models, name))
        attributes.clear()
        attributes.update(kept)


def recount_topics(models: Models, frames: Sequence[Frame]) -> None:
    """The Messages screen's topics as the last `TOPICS_WINDOW` of `frames` leave them."""
    topics = models.topics
    clock = topics.clock
    vars(topics).clear()
    topics.__init__(clock)  # type: ignore[misc]  # the same object: the screen keeps it
    for _, same_second in itertools.groupby(frames[-TOPICS_WINDOW:], key=lambda f: int(f.t)):
        batch = list(same_second)  # the model counts rates by the second
        topics.count([f.env for f in batch], now=batch[-1].t)


@dataclass
class ReplayIndex:
    """Keyframes, marks and log lines of one tape (module doc)."""

    keyframes: list[Keyframe]
    marks: list[Mark] = field(default_factory=list)
    lines: list[LogEntry] = field(default_factory=list)
    line_index: list[int] = field(default_factory=list)  # per line: its message's index

    @classmethod
    def build(cls, frames: Sequence[Frame], intake: BusIntake,
              every: int = KEYFRAME_EVERY) -> ReplayIndex:
        """Index `frames` with `intake` (its models are a fresh copy: they are changed)."""
        models = intake.models
        index = cls([Keyframe(0, capture(models), None)])
        mind: Mind | None = None
        for i, frame in enumerate(frames):
            if i and i % every == 0:
                index.keyframes.append(Keyframe(i, capture(models), mind))
            before = _alert_counts(models)
            changes = intake.take([frame.env])
            mind = changes.mind or mind
            index.lines.extend(changes.lines)
            index.line_index.extend([i] * len(changes.lines))
            index._mark(frame, i, before if "alerts" in changes.panels else None, models)
        return index

    def _mark(self, frame: Frame, i: int, before: dict[tuple[str, str], int] | None,
              models: Models) -> None:
        body = frame.env.body
        if isinstance(body, ActionStatus) and body.state is ActionState.FAILED \
                and not body.repeat:
            self.marks.append(Mark(MarkKind.ACTION_FAILED, frame.t, i,
                                   f"{body.name or body.uuid[:8]} on {body.robot}: "
                                   f"{body.reason}"))
        elif isinstance(body, SupEvent) and body.event is SupEventKind.RESTART:
            self.marks.append(Mark(MarkKind.RESTART, frame.t, i,
                                   f"{body.child}: {body.reason}"))
        if before is not None:
            raised = [a.line() for key, a in models.alerts.alerts.items()
                      if before.get(key) != a.count]
            if raised:  # one mark a message: a seek goes to the message
                self.marks.append(Mark(MarkKind.ALERT, frame.t, i, "; ".join(raised)))

    def keyframe_before(self, index: int) -> Keyframe:
        """The last keyframe at or before message `index`."""
        at = bisect_right([k.index for k in self.keyframes], index) - 1
        return self.keyframes[max(at, 0)]

    def lines_before(self, index: int, most: int) -> list[LogEntry]:
        """The last `most` log lines of the messages before `index`."""
        end = bisect_right(self.line_index, index - 1)
        return self.lines[max(0, end - most):end]

    def next_mark(self, kind: MarkKind, index: int) -> Mark | None:
        """The first mark of `kind` made by message `index` or later."""
        return next((m for m in self.marks if m.kind is kind and m.index >= index), None)


def _alert_counts(models: Models) -> dict[tuple[str, str], int]:
    return {key: alert.count for key, alert in models.alerts.alerts.items()}


def fresh_models(models: Models) -> Models:
    """A copy of `models` (as they are now) for an index pass to change."""
    return dataclasses.replace(models, **{name: copy.deepcopy(getattr(models, name))
                                          for name in (*KEPT, "liveness")})
