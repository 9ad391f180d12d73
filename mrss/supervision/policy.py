"""The restart rule book shared by process and actor supervisors; pure, no I/O.

`RestartPolicy.child_exited` is the single place where a child's exit is turned into a
`Decision`: leave it down, restart it (and which siblings with it, after what delay),
quarantine it (or its group), or escalate. The clock and the random source are injected,
so the rules are tested with a fake clock. Rules, in the order they are applied:

1. A temporary child is never restarted; a transient child is not restarted after a
   normal exit. Neither affects its siblings.
   A child that refused its configuration at start (`config_error`: a ConfigError in
   `start`, e.g. an agent program with load-time errors) is given up at once, as in
   rule 4 or 5, and never retried: a restart would fail the same way.
2. Budgets are per child: a restart is counted in the child's own intensity window
   unless the cause is a lost link, and more than `intensity` restarts of that child
   within `period` seconds exceed its budget. A sibling's restarts never use up a
   child's budget. Opt-in, `shared_intensity` also counts every restart in one
   supervisor-wide window; exceeding that escalates (rule 5), whatever `on_exceeded`.
3. Subtrees: a child of a group that exceeds its budget escalates to its group, and no
   further: the group's running members are stopped in reverse start order and every
   member starts again at once, in start order, with fresh budgets and streaks. That
   counts once in the group's own window (`Group.intensity`, 1 by default, within its
   `period`, by default the supervisor's). Children outside the group are not touched.
4. Giving up: an ungrouped child over its budget, or a group over its window, is the
   culprit. With `on_exceeded = quarantine` only the culprit is taken out: its running
   members are stopped in reverse start order and all stay down for `probation`
   seconds (`inf`: for good), then `release` retries them with fresh budgets.
5. With `on_exceeded = escalate` (or the shared window exceeded) every child is stopped
   in reverse start order and the supervisor fails to its parent.
6. Otherwise the strategy picks the children to restart: one_for_one the child,
   one_for_all every active child, rest_for_one the child and every active child after
   it. Running siblings among them are stopped first, in reverse start order;
   temporary siblings stopped this way are not started again.
7. The delay comes from the backoff and the child's failure streak (forgotten once the
   child has run for `healthy_after` seconds), less the time its last incarnation ran:
   backoff spaces the starts of a crash loop, so a child that ran longer than its delay
   is restarted at once. A child with `backoff = False` (the bus proxy) always is.
"""

from __future__ import annotations

import math
import random
import time
from collections import deque
from collections.abc import Callable, Collection, Iterable
from dataclasses import dataclass
from enum import StrEnum
from typing import Any

from mrss.errors import SupervisionError
from mrss.supervision.reason import Cause, ExitReason
from mrss.supervision.spec import (
    ChildSpec,
    Group,
    OnExceeded,
    Restart,
    Strategy,
    SupervisorSpec,
)

Clock = Callable[[], float]


class Action(StrEnum):
    """What a supervisor does about one child's exit."""

    LEAVE = "leave"  # the child stays down; nothing else happens
    RESTART = "restart"  # the child (with siblings per strategy, or its whole group)
    QUARANTINE = "quarantine"  # the child, or its group, stays down for `delay` seconds
    ESCALATE = "escalate"  # every child stops; the supervisor fails


@dataclass(frozen=True)
class Decision:
    """The outcome of one exit: the action and the children it touches, in order."""

    action: Action
    child: str
    reason: ExitReason
    stop: tuple[str, ...] = ()  # running siblings to stop first, in this order
    restart: tuple[str, ...] = ()  # children to start again, in this order
    drop: tuple[str, ...] = ()  # children that stay down (for good, or quarantined)
    delay: float = 0.0  # seconds before the first start (backoff, or probation)
    count: int = 0  # the child's total restarts, this one included
    note: str = ""
    group: str = ""  # the subtree that escalated, restarts or is quarantined as one


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

    def used(self, now: float) -> int:
        """Restarts counted within the last `period` seconds at `now`."""
        return sum(1 for t in self._times if t > now - self.period)

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
        self._child_windows: dict[str, RestartIntensity] = {}
        self._shared = None if spec.shared_intensity is None \
            else RestartIntensity(spec.shared_intensity, spec.period)
        self._groups: dict[str, Group] = {g.name: g for g in spec.groups}
        self._group_of = {c: g for g in spec.groups for c in g.children}
        self._group_windows = {g.name: RestartIntensity(g.intensity, g.period or spec.period)
                               for g in spec.groups}
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

    def budget(self, child: str, now: float) -> tuple[int, int, float]:
        """The child's own budget at `now` (rule 2): restarts counted, limit, period."""
        window = self._child_windows[child]
        return window.used(now), window.limit, window.period

    def streak(self, child: str) -> int:
        return self._record(child).streak

    def spec_of(self, child: str) -> ChildSpec[Any]:
        return self._record(child).spec

    def group_of(self, child: str) -> str:
        """The name of the child's group ("" when it is in none)."""
        group = self._group_of.get(child)
        return group.name if group is not None else ""

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
        """End a quarantine: the child is active again with a clean slate (its group too)."""
        record = self._record(child)
        record.quarantined = False
        record.active = True
        record.streak = 0
        self._child_windows[child].clear()
        group = self._group_of.get(child)
        if group is not None:
            self._group_windows[group.name].clear()

    def child_exited(
        self, child: str, reason: ExitReason, *, running: Collection[str] = (),
    ) -> Decision:
        """Turn an unexpected exit into a decision; `running` are the siblings still up."""
        record = self._record(child)
        now = self._clock()
        ran = now - record.started_at if record.started_at is not None else 0.0
        healthy = record.started_at is not None and ran >= self.spec.healthy_after
        record.started_at = None
        restart = record.spec.restart
        # Rule 1: temporary and transient children.
        if restart is Restart.TEMPORARY or (restart is Restart.TRANSIENT and reason.normal):
            record.active = False
            why = "temporary" if restart is Restart.TEMPORARY else "transient, normal exit"
            return Decision(Action.LEAVE, child, reason, drop=(child,), note=why)

        record.streak = 1 if healthy else record.streak + 1
        if reason.cause is Cause.CONFIG_ERROR:  # Rule 1b: a restart would fail the same way
            return self._give_up(record, reason, running, (child,), "",
                                 "configuration error: not restarted until it is fixed",
                                 retry=False)
        if reason.counts_toward_intensity:
            # Rule 2: the opt-in shared window, then the child's own budget.
            if self._shared is not None and not self._shared.add(now):
                return self._escalate(record, reason, running, self._limit(
                    self._shared.limit, "restarts of all children"))
            if not self._child_windows[child].add(now):
                exceeded = self._limit(self.spec.intensity, f"restarts of {child}")
                group = self._group_of.get(child)
                if group is not None:  # Rule 3
                    return self._group_exceeded(group, record, reason, running, now, exceeded)
                return self._give_up(record, reason, running, (child,), "", exceeded)
        record.restarts += 1
        # Rule 6: the strategy's group; rule 7: the delay.
        group_ids = self._strategy_group(child)
        stop = tuple(c for c in reversed(group_ids) if c != child and c in running)
        drop = tuple(c for c in stop if self._children[c].spec.restart is Restart.TEMPORARY)
        for c in drop:
            self._children[c].active = False
        restart_ids = tuple(c for c in group_ids if c not in drop)
        return Decision(
            Action.RESTART, child, reason, stop=stop, restart=restart_ids, drop=drop,
            delay=self._delay(record, ran), count=record.restarts,
            note=f"{self.spec.strategy.value}",
        )

    # -- rules 3 to 5 --------------------------------------------------------------------
    def _group_exceeded(
        self, group: Group, record: _ChildRecord, reason: ExitReason,
        running: Collection[str], now: float, exceeded: str,
    ) -> Decision:
        members = self._members(group)
        if not self._group_windows[group.name].add(now):
            window = self._group_windows[group.name]
            return self._give_up(record, reason, running, members, group.name,
                                 f"{exceeded}, and more than {window.limit} restarts of group "
                                 f"{group.name} in {window.period:g}s")
        stop = tuple(c for c in reversed(members) if c != record.spec.id and c in running)
        drop = tuple(c for c in stop if self._children[c].spec.restart is Restart.TEMPORARY)
        for c in members:
            member = self._children[c]
            member.streak = 0
            self._child_windows[c].clear()
            if c in drop:
                member.active = False
        record.restarts += 1
        return Decision(
            Action.RESTART, record.spec.id, reason, stop=stop,
            restart=tuple(c for c in members if c not in drop), drop=drop,
            count=record.restarts, group=group.name,
            note=f"{exceeded}: group {group.name} restarts as a whole",
        )

    def _give_up(
        self, record: _ChildRecord, reason: ExitReason, running: Collection[str],
        members: tuple[str, ...], group: str, note: str, *, retry: bool = True,
    ) -> Decision:
        if self.spec.on_exceeded is not OnExceeded.QUARANTINE:
            return self._escalate(record, reason, running, note)
        for c in members:
            self._children[c].active = False
            self._children[c].quarantined = True
        stop = tuple(c for c in reversed(members) if c != record.spec.id and c in running)
        return Decision(
            Action.QUARANTINE, record.spec.id, reason, stop=stop, drop=members,
            delay=self.spec.probation if retry else math.inf, count=record.restarts,
            note=note, group=group,
        )

    def _escalate(
        self, record: _ChildRecord, reason: ExitReason, running: Collection[str], note: str,
    ) -> Decision:
        child = record.spec.id
        stop = tuple(c for c in reversed(self._children) if c in running and c != child)
        for r in self._children.values():
            r.active = False
        return Decision(
            Action.ESCALATE, child, reason, stop=stop, drop=tuple(self._children),
            count=record.restarts, note=note,
        )

    # -- helpers -----------------------------------------------------------------------
    def _limit(self, limit: int, what: str) -> str:
        return f"more than {limit} {what} in {self.spec.period:g}s"

    def _delay(self, record: _ChildRecord, ran: float) -> float:
        if not record.spec.backoff:
            return 0.0
        return max(0.0, self.spec.backoff.delay(record.streak, self._rand()) - ran)

    def _members(self, group: Group) -> tuple[str, ...]:
        """The group's children that this supervisor has and that should run, in order."""
        return tuple(c for c in self._children if self._group_of.get(c) is group
                     and (self._children[c].active or self._children[c].quarantined))

    def _strategy_group(self, child: str) -> list[str]:
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
