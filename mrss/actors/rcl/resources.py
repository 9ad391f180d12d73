"""Named resources shared by skills, arbitrated by action priority (DESIGN.md, "Skills").

The one rule (docs/rcl.md and the template state it in the same words):
    A resource is held by one action at a time (its skills share it). A request
    pre-empts the holder if its priority is strictly higher; otherwise it waits.
    Whenever the resource is free it goes to the highest-priority candidate among the
    actions waiting for it and those pre-empted from it, the oldest request first among
    equals.

A holder whose skill is inside a critical section (`Skill.critical`) is pre-empted when
the section ends (the lifecycle defers its suspension, skill_actor.py holds the
interrupt): until then it keeps the resource and the request waits.

`ResourceSchedule` applies the rule and nothing else: pure, no threads, no locks; each
call returns a `Decision` (tokens granted, actions to pre-empt, pre-empted actions to
resume). A pre-empted action chosen when its resource frees has the resource reserved
for it until its skills, restarted by the resume, take it back (or it ends, or another
suspension releases its resources). Its age is that of its first request, kept across
the pre-emption. `ResourceBroker` wraps the schedule for skills on their own threads:
it blocks `acquire` until granted and runs the callbacks outside its lock.
"""

from __future__ import annotations

import itertools
import logging
import threading
import time
from collections.abc import Callable
from dataclasses import dataclass, field
from typing import NamedTuple

from mrss.actors.rcl.skill import SkillInterrupted
from mrss.errors import ActionError

log = logging.getLogger("mrss.rcl.resources")


class Holder(NamedTuple):
    """Who asks for a resource: one running skill (`token`) of an action."""

    token: str
    uuid: str
    priority: int


class Candidate(NamedTuple):
    """An action with a claim on a resource: its priority and the age of its request."""

    uuid: str
    priority: int
    seq: int

    def rank(self) -> tuple[int, int]:
        """Smaller is served first: highest priority, then oldest."""
        return (-self.priority, self.seq)


@dataclass
class Decision:
    """What a schedule call decided: who now holds, who to pre-empt, who to resume."""

    granted: list[str] = field(default_factory=list)  # tokens
    preempt: list[tuple[str, str]] = field(default_factory=list)  # (uuid, resource)
    resume: list[tuple[str, str]] = field(default_factory=list)  # (uuid, resource)

    def merge(self, other: Decision) -> Decision:
        self.granted += other.granted
        self.preempt += other.preempt
        self.resume += other.resume
        return self


@dataclass
class _Resource:
    holders: dict[str, Holder] = field(default_factory=dict)  # token -> holder
    since: int = 0  # age of the holding action's request
    waiters: dict[str, tuple[Holder, int]] = field(default_factory=dict)  # token -> (h, seq)
    preempted: dict[str, Candidate] = field(default_factory=dict)
    reserved: Candidate | None = None  # a resumed pre-empted action, until it takes it

    def holder(self) -> Candidate | None:
        """The action holding (or reserved) the resource."""
        if self.reserved is not None:
            return self.reserved
        h = next(iter(self.holders.values()), None)
        return None if h is None else Candidate(h.uuid, h.priority, self.since)

    def candidates(self) -> list[Candidate]:
        waiting = {h.uuid: Candidate(h.uuid, h.priority, seq) for h, seq in self.waiters.values()}
        return [*waiting.values(), *self.preempted.values()]


class ResourceSchedule:
    """Pure bookkeeping of every resource: applies the rule of the module docstring."""

    def __init__(self) -> None:
        self._resources: dict[str, _Resource] = {}
        self._seq = itertools.count()

    # -- what skills and actions do ----------------------------------------------------
    def request(self, resource: str, holder: Holder) -> Decision:
        """Skill `holder.token` asks for `resource`: granted now, or it waits (and may
        pre-empt a lower-priority holder)."""
        st = self._resources.setdefault(resource, _Resource())
        old = st.preempted.pop(holder.uuid, None)
        seq = old.seq if old is not None else next(self._seq)
        if st.reserved is not None and st.reserved.uuid == holder.uuid:
            seq, st.reserved = st.reserved.seq, None
        current = st.holder()
        if current is not None and current.uuid == holder.uuid:  # its action holds it
            st.holders[holder.token] = holder
            return Decision(granted=[holder.token])
        st.waiters[holder.token] = (holder, seq)
        decision = Decision()
        if (current is not None and current.priority < holder.priority
                and current.uuid not in st.preempted):
            decision.preempt.append((current.uuid, resource))
            st.preempted[current.uuid] = current
            if st.reserved is not None:  # handed over, not yet taken: just take it back
                st.reserved = None
        return decision.merge(self._settle(resource, st))

    def release(self, resource: str, token: str) -> Decision:
        """Skill `token` gives `resource` back (or stops waiting for it)."""
        st = self._resources.get(resource)
        if st is None:
            return Decision()
        if st.holders.pop(token, None) is None and st.waiters.pop(token, None) is None:
            return Decision()
        return self._settle(resource, st)

    def release_token(self, token: str) -> Decision:
        """Everything skill `token` holds or waits for (it finished or was abandoned)."""
        decision = Decision()
        for name in list(self._resources):
            decision.merge(self.release(name, token))
        return decision

    def forget(self, uuid: str) -> Decision:
        """Action `uuid` ended or was suspended by other than a pre-emption: it holds,
        waits for, and has a claim on nothing any more."""
        decision = Decision()
        for name, st in self._resources.items():
            before = (len(st.holders), len(st.waiters), len(st.preempted), st.reserved)
            st.holders = {t: h for t, h in st.holders.items() if h.uuid != uuid}
            st.waiters = {t: w for t, w in st.waiters.items() if w[0].uuid != uuid}
            st.preempted.pop(uuid, None)
            if st.reserved is not None and st.reserved.uuid == uuid:
                st.reserved = None
            if before != (len(st.holders), len(st.waiters), len(st.preempted), st.reserved):
                decision.merge(self._settle(name, st))
        return decision

    # -- the rule: a free resource goes to the best candidate ------------------------------
    def _settle(self, name: str, st: _Resource) -> Decision:
        if st.holders or st.reserved is not None:
            return Decision()
        candidates = st.candidates()
        if not candidates:
            return Decision()
        best = min(candidates, key=Candidate.rank)
        if best.uuid in st.preempted:
            del st.preempted[best.uuid]
            st.reserved = best
            return Decision(resume=[(best.uuid, name)])
        granted = [t for t, (h, _) in st.waiters.items() if h.uuid == best.uuid]
        for token in granted:
            st.holders[token] = st.waiters.pop(token)[0]
        st.since = best.seq
        return Decision(granted=granted)

    # -- views ------------------------------------------------------------------------------
    def holder(self, resource: str) -> Candidate | None:
        """The action holding `resource`, or the one it is reserved for."""
        st = self._resources.get(resource)
        return st.holder() if st else None

    def holders(self, resource: str) -> set[str]:
        st = self._resources.get(resource)
        return {h.uuid for h in st.holders.values()} if st else set()

    def candidates(self, resource: str) -> list[Candidate]:
        """Waiting and pre-empted actions, in the order they will get `resource`."""
        st = self._resources.get(resource)
        return sorted(st.candidates(), key=Candidate.rank) if st else []

    def waiting(self, resource: str) -> list[str]:
        st = self._resources.get(resource)
        if st is None:
            return []
        ws = sorted({h.uuid: (seq, h) for h, seq in st.waiters.values()}.values(),
                    key=lambda w: (-w[1].priority, w[0]))
        return [h.uuid for _, h in ws]


Callback = Callable[[str, str], None]  # (action uuid, resource name)


class ResourceBroker:
    """Grants named resources to skills by the schedule's rule; thread-safe."""

    def __init__(self, preempt: Callback, resume: Callback) -> None:
        self._preempt = preempt
        self._resume = resume
        self._lock = threading.Lock()
        self._schedule = ResourceSchedule()
        self._granted: dict[str, threading.Event] = {}  # waiting tokens -> their wake-up
        self._wake: dict[str, threading.Event] = {}

    def acquire(self, resource: str, holder: Holder, interrupt: threading.Event,
                timeout: float | None = None,
                on_wait: Callable[[list[str]], None] | None = None) -> None:
        """Block until `holder` holds `resource`; SkillInterrupted / ActionError (timeout).

        When it has to wait, `on_wait` is called first (outside the lock) with the uuids
        of the actions it waits behind: those holding the resource, then those ahead of
        it in the queue (so an observer can say "queued for uav1.motion behind ...")."""
        with self._lock:
            decision = self._schedule.request(resource, holder)
            granted = holder.token in decision.granted
            if granted:
                decision.granted.remove(holder.token)
            wake = threading.Event()
            behind: list[str] = []
            if not granted:
                self._wake[holder.token] = wake
                queue = self._schedule.waiting(resource)
                ahead = queue[:queue.index(holder.uuid)] if holder.uuid in queue else queue
                behind = [u for u in (*sorted(self._schedule.holders(resource)), *ahead)
                          if u != holder.uuid]
            self._apply_locked(decision)
        self._callbacks(decision)
        if granted:
            return
        if on_wait is not None:
            on_wait(behind)
        log.info("action %s waits for %s (priority %d)", holder.uuid, resource,
                 holder.priority)
        deadline = None if timeout is None else time.monotonic() + timeout
        while True:
            left = None if deadline is None else max(0.0, deadline - time.monotonic())
            wake.wait(left)
            with self._lock:
                if self._granted.pop(holder.token, None) is not None:
                    return
                expired = deadline is not None and time.monotonic() >= deadline
                if not (interrupt.is_set() or expired):
                    wake.clear()
                    continue
                self._wake.pop(holder.token, None)
                decision = self._schedule.release(resource, holder.token)
                self._apply_locked(decision)
            self._callbacks(decision)
            if interrupt.is_set():
                raise SkillInterrupted(f"interrupted while waiting for resource {resource!r}")
            raise ActionError(f"resource {resource!r} not granted within {timeout}s",
                              uuid=holder.uuid)

    def wake(self, token: str) -> None:
        """Wake the waits of skill `token` so they notice their interruption."""
        with self._lock:
            wake = self._wake.get(token)
        if wake is not None:
            wake.set()

    def release(self, resource: str, token: str) -> None:
        """Skill `token` gives `resource` back."""
        self._run(lambda: self._schedule.release(resource, token))

    def release_token(self, token: str) -> None:
        """Release everything skill `token` holds (it finished or was abandoned)."""
        self._run(lambda: self._schedule.release_token(token))

    def forget_action(self, uuid: str) -> None:
        """The action ended or was suspended for good: release what it holds, drop its
        waits and its claim as a pre-empted action."""
        self._run(lambda: self._schedule.forget(uuid))
        with self._lock:  # its waiting skills notice they were dropped
            wakes = [w for t, w in self._wake.items() if t.startswith(f"{uuid}/")]
        for w in wakes:
            w.set()

    def holders(self, resource: str) -> set[str]:
        """Uuids of the actions holding `resource` now."""
        with self._lock:
            return self._schedule.holders(resource)

    def waiting(self, resource: str) -> list[str]:
        """Uuids of the actions waiting for `resource`, in the order they will get it."""
        with self._lock:
            return self._schedule.waiting(resource)

    def _run(self, call: Callable[[], Decision]) -> None:
        with self._lock:
            decision = call()
            self._apply_locked(decision)
        self._callbacks(decision)

    def _apply_locked(self, decision: Decision) -> None:
        for token in decision.granted:
            wake = self._wake.pop(token, None)
            if wake is not None:
                self._granted[token] = wake
                wake.set()

    def _callbacks(self, decision: Decision) -> None:
        for uuid, resource in decision.preempt:
            log.info("action %s pre-empted: %s wanted by a higher-priority action",
                     uuid, resource)
            self._preempt(uuid, resource)
        for uuid, resource in decision.resume:
            log.info("resource %s goes to pre-empted action %s: resuming it", resource, uuid)
            self._resume(uuid, resource)
