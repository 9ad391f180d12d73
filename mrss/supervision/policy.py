"""The restart rule book shared by process and actor supervisors; pure, no I/O.

`RestartPolicy.child_exited` is the single place where a child's exit is turned into a
`Decision`: leave it down, restart it (and which siblings with it, after what delay),
quarantine it, or escalate. The clock and the random source are injected, so the rules
are tested with a fake clock. Rules, in the order they are applied:

1. A temporary child is never restarted; a transient child is not restarted after a
   normal exit. Neither affects its siblings.
2. A restart is counted in the intensity window (per supervisor; per child when the
   supervisor quarantines) unless the cause is a lost link. More than `intensity`
   restarts within `period` seconds exceeds the intensity.
3. Exceeded: escalate (stop every child, the supervisor fails) or quarantine (only this
   child is taken out for `probation` seconds, then retried with a clean slate).
4. Otherwise the strategy picks the children to restart: one_for_one the child,
   one_for_all every active child, rest_for_one the child and every active child after
   it. Running siblings among them are stopped first, in reverse start order;
   temporary siblings stopped this way are not started again.
5. The delay comes from the backoff and the child's failure streak, which is forgotten
   once the child has run for `healthy_after` seconds.
"""

from __future__ import annotations

import random
import time
from collections import deque
from collections.abc import Callable, Collection, Iterable
from dataclasses import dataclass
from enum import StrEnum
from typing import Any

from mrss.errors import SupervisionError
from mrss.supervision.reason import ExitReason
from mrss.supervision.spec import ChildSpec, OnExceeded, Restart, Strategy, SupervisorSpec

Clock = Callable[[], float]


class Action(StrEnum):
    """What a supervisor does about one child's exit."""

    LEAVE = "leave"  # the child stays down; nothing else happens
    RESTART = "restart"
    QUARANTINE = "quarantine"
    ESCALATE = "escalate"


@dataclass(frozen=True)
class Decision:
    """The outcome of one exit: the action and the children it touches, in order."""

    action: Action
    child: str
    reason: ExitReason
    stop: tuple[str, ...] = ()  # running siblings to stop first, in this order
    restart: tuple[str, ...] = ()  # children to start again, in this order
    drop: tuple[str, ...] = ()  # children that stay down for good
    delay: float = 0.0  # seconds before the first start (backoff, or probation)
    count: int = 0  # the child's total restarts, this one included
    note: str = ""


class RestartIntensity:
    """A sliding window of restart times: more than `limit` within `period` exceeds it."""

    def __init__(self, limit: int, period: float) -> None:
        self.limit = limit
        self.period = period
        self._times: deque[float] = deque()

    def add(self, now: float) -> bool:
        """Record a restart at `now`; True while the intensity is not exceeded."""
        self._times.append(now)
        while self._times and self._times[0] <= now - self.period:
            self._times.popleft()
        return len(self._times) <= self.limit

    def clear(self) -> None:
        self._times.clear()

    def __len__(self) -> int:
        return len(self._times)


@dataclass
class _ChildRecord:
    spec: ChildSpec[Any]
    active: bool = True  # False once it finished, was dropped, or is quarantined
    quarantined: bool = False
    started_at: float | None = None
    restarts: int = 0
    streak: int = 0


class RestartPolicy:
    """Decides restarts for one supervisor's ordered children (see the module rules)."""

    def __init__(
        self, spec: SupervisorSpec, children: Iterable[ChildSpec[Any]] = (),
        *, clock: Clock = time.monotonic, rand: Callable[[], float] = random.random,
    ) -> None:
        self.spec = spec
        self._clock = clock
        self._rand = rand
        self._children: dict[str, _ChildRecord] = {}
        self._window = RestartIntensity(spec.intensity, spec.period)
        self._child_windows: dict[str, RestartIntensity] = {}
        for child in children:
            self.add_child(child)

    # -- membership --------------------------------------------------------------------
    def add_child(self, spec: ChildSpec[Any]) -> None:
        """Append a child (it starts after every existing child)."""
        if spec.id in self._children:
            raise SupervisionError(f"duplicate child id {spec.id!r}")
        self._children[spec.id] = _ChildRecord(spec)
        self._child_windows[spec.id] = RestartIntensity(self.spec.intensity, self.spec.period)

    def remove_child(self, child: str) -> None:
        self._record(child)
        del self._children[child]
        del self._child_windows[child]

    @property
    def order(self) -> list[str]:
        """Every child id in start order."""
        return list(self._children)

    def active(self, child: str) -> bool:
        """Whether the child should be running (not finished, dropped or quarantined)."""
        return self._record(child).active

    def restarts(self, child: str) -> int:
        return self._record(child).restarts

    def streak(self, child: str) -> int:
        return self._record(child).streak

    def spec_of(self, child: str) -> ChildSpec[Any]:
        return self._record(child).spec

    # -- lifecycle ---------------------------------------------------------------------
    def child_started(self, child: str) -> None:
        """The child is up (ready); its healthy-run clock starts now."""
        record = self._record(child)
        record.started_at = self._clock()
        record.active = True

    def child_stopped(self, child: str) -> None:
        """The child was stopped on purpose; no decision is needed."""
        self._record(child).started_at = None

    def release(self, child: str) -> None:
        """End a quarantine: the child is active again with a clean slate."""
        record = self._record(child)
        record.quarantined = False
        record.active = True
        record.streak = 0
        self._child_windows[child].clear()

    def child_exited(
        self, child: str, reason: ExitReason, *, running: Collection[str] = (),
    ) -> Decision:
        """Turn an unexpected exit into a decision; `running` are the siblings still up."""
        record = self._record(child)
        now = self._clock()
        healthy = record.started_at is not None and \
            now - record.started_at >= self.spec.healthy_after
        record.started_at = None
        restart = record.spec.restart
        if restart is Restart.TEMPORARY or (restart is Restart.TRANSIENT and reason.normal):
            record.active = False
            why = "temporary" if restart is Restart.TEMPORARY else "transient, normal exit"
            return Decision(Action.LEAVE, child, reason, drop=(child,), note=why)

        record.streak = 1 if healthy else record.streak + 1
        if reason.counts_toward_intensity:
            window = self._child_windows[child] \
                if self.spec.on_exceeded is OnExceeded.QUARANTINE else self._window
            if not window.add(now):
                return self._exceeded(record, reason, running)
        record.restarts += 1
        group = self._group(child)
        stop = tuple(c for c in reversed(group) if c != child and c in running)
        drop = tuple(c for c in stop if self._children[c].spec.restart is Restart.TEMPORARY)
        for c in drop:
            self._children[c].active = False
        restart_ids = tuple(c for c in group if c not in drop)
        delay = self.spec.backoff.delay(record.streak, self._rand())
        return Decision(
            Action.RESTART, child, reason, stop=stop, restart=restart_ids, drop=drop,
            delay=delay, count=record.restarts, note=f"{self.spec.strategy.value}",
        )

    # -- helpers -----------------------------------------------------------------------
    def _exceeded(
        self, record: _ChildRecord, reason: ExitReason, running: Collection[str],
    ) -> Decision:
        limit = f"more than {self.spec.intensity} restarts in {self.spec.period:g}s"
        child = record.spec.id
        if self.spec.on_exceeded is OnExceeded.QUARANTINE:
            record.active = False
            record.quarantined = True
            return Decision(
                Action.QUARANTINE, child, reason, delay=self.spec.probation,
                count=record.restarts, note=limit,
            )
        stop = tuple(c for c in reversed(self._children) if c in running and c != child)
        for r in self._children.values():
            r.active = False
        return Decision(
            Action.ESCALATE, child, reason, stop=stop, drop=tuple(self._children),
            count=record.restarts, note=limit,
        )

    def _group(self, child: str) -> list[str]:
        ids = self.order
        if self.spec.strategy is Strategy.ONE_FOR_ONE:
            return [child]
        if self.spec.strategy is Strategy.REST_FOR_ONE:
            ids = ids[ids.index(child):]
        return [c for c in ids if c == child or self._children[c].active]

    def _record(self, child: str) -> _ChildRecord:
        try:
            return self._children[child]
        except KeyError:
            raise SupervisionError(f"no child {child!r} in this supervisor") from None
