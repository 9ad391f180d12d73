"""Named resources shared by skills, arbitrated by action priority (DESIGN.md, "Skills").

Rules, each in one place below:
- a free resource goes to the requester unless a waiter of equal or higher priority is
  ahead of it; the skills of one action share what their action holds;
- a request for a resource held only by lower-priority actions pre-empts them (the
  `preempt` callback suspends them) and waits until they have let go;
- otherwise (a holder of equal or higher priority) the requester waits its turn:
  highest priority first, first come first served among equals;
- when a resource ends up free with nobody waiting, the actions pre-empted for it are
  handed to the `resume` callback.
Callbacks run outside the lock, on the thread that caused them.
"""

from __future__ import annotations

import itertools
import logging
import threading
import time
from collections.abc import Callable
from dataclasses import dataclass, field
from typing import NamedTuple

from mrss.api import SkillInterrupted
from mrss.errors import ActionError

log = logging.getLogger("mrss.rcl.resources")


class Holder(NamedTuple):
    """Who asks for a resource: one running skill (`token`) of an action."""

    token: str
    uuid: str
    priority: int


@dataclass
class _Waiter:
    holder: Holder
    seq: int
    wake: threading.Event = field(default_factory=threading.Event)
    granted: bool = False


@dataclass
class _ResourceState:
    holders: dict[str, Holder] = field(default_factory=dict)
    waiters: list[_Waiter] = field(default_factory=list)
    preempted: set[str] = field(default_factory=set)


Callback = Callable[[str, str], None]  # (action uuid, resource name)


class ResourceBroker:
    """Grants named resources to skills; thread-safe."""

    def __init__(self, preempt: Callback, resume: Callback) -> None:
        self._preempt = preempt
        self._resume = resume
        self._lock = threading.Lock()
        self._resources: dict[str, _ResourceState] = {}
        self._seq = itertools.count()

    def acquire(self, resource: str, holder: Holder, interrupt: threading.Event,
                timeout: float | None = None) -> None:
        """Block until `holder` holds `resource`; SkillInterrupted / ActionError (timeout)."""
        victims: list[str] = []
        with self._lock:
            st = self._resources.setdefault(resource, _ResourceState())
            if self._grantable(st, holder):
                st.holders[holder.token] = holder
                return
            waiter = _Waiter(holder, next(self._seq))
            st.waiters.append(waiter)
            others = [h for h in st.holders.values() if h.uuid != holder.uuid]
            if others and all(h.priority < holder.priority for h in others):
                victims = sorted({h.uuid for h in others} - st.preempted)
                st.preempted.update(victims)
        for uuid in victims:
            log.info("action %s pre-empted: %s wanted by higher-priority action %s",
                     uuid, resource, holder.uuid)
            self._preempt(uuid, resource)
        self._wait(resource, waiter, interrupt, timeout)

    def _wait(self, resource: str, waiter: _Waiter, interrupt: threading.Event,
              timeout: float | None) -> None:
        deadline = None if timeout is None else time.monotonic() + timeout
        while True:
            left = None if deadline is None else max(0.0, deadline - time.monotonic())
            waiter.wake.wait(left)
            with self._lock:
                if waiter.granted:
                    return
                expired = deadline is not None and time.monotonic() >= deadline
                if not (interrupt.is_set() or expired):
                    waiter.wake.clear()
                    continue
                st = self._resources[resource]
                st.waiters.remove(waiter)
                resumes = self._settle(resource, st)
            self._call_resume(resumes, resource)
            if interrupt.is_set():
                raise SkillInterrupted(f"interrupted while waiting for resource {resource!r}")
            raise ActionError(f"resource {resource!r} not granted within {timeout}s",
                              uuid=waiter.holder.uuid)

    def wake(self, token: str) -> None:
        """Wake the waits of skill `token` so they notice their interruption."""
        with self._lock:
            for st in self._resources.values():
                for w in st.waiters:
                    if w.holder.token == token:
                        w.wake.set()

    def release(self, resource: str, token: str) -> None:
        """Skill `token` gives `resource` back."""
        with self._lock:
            st = self._resources.get(resource)
            if st is None or st.holders.pop(token, None) is None:
                return
            resumes = self._settle(resource, st)
        self._call_resume(resumes, resource)

    def release_token(self, token: str) -> None:
        """Release everything skill `token` holds (it finished or was abandoned)."""
        self._drop(lambda h: h.token == token, forget=None)

    def forget_action(self, uuid: str) -> None:
        """The action ended: release what it holds, drop its waits and pre-emption marks."""
        self._drop(lambda h: h.uuid == uuid, forget=uuid)

    def _drop(self, match: Callable[[Holder], bool], forget: str | None) -> None:
        calls: list[tuple[list[str], str]] = []
        with self._lock:
            for name, st in self._resources.items():
                before = len(st.holders) + len(st.waiters) + len(st.preempted)
                st.holders = {t: h for t, h in st.holders.items() if not match(h)}
                for w in [w for w in st.waiters if match(w.holder)]:
                    st.waiters.remove(w)
                    w.wake.set()
                if forget is not None:
                    st.preempted.discard(forget)
                if len(st.holders) + len(st.waiters) + len(st.preempted) != before:
                    calls.append((self._settle(name, st), name))
        for resumes, name in calls:
            self._call_resume(resumes, name)

    def holders(self, resource: str) -> set[str]:
        """Uuids of the actions holding `resource` now."""
        with self._lock:
            st = self._resources.get(resource)
            return {h.uuid for h in st.holders.values()} if st else set()

    def waiting(self, resource: str) -> list[str]:
        """Uuids of the actions waiting for `resource`, in the order they will get it."""
        with self._lock:
            st = self._resources.get(resource)
            ws = sorted(st.waiters, key=lambda w: (-w.holder.priority, w.seq)) if st else []
            return [w.holder.uuid for w in ws]

    def _grantable(self, st: _ResourceState, holder: Holder) -> bool:
        if st.holders:
            return all(h.uuid == holder.uuid for h in st.holders.values())
        return not any(w.holder.priority >= holder.priority for w in st.waiters)

    def _settle(self, name: str, st: _ResourceState) -> list[str]:
        """Hand a free resource to the best waiter; return pre-empted actions to resume."""
        if not st.holders and st.waiters:
            best = min(st.waiters, key=lambda w: (-w.holder.priority, w.seq))
            for w in [w for w in st.waiters if w.holder.uuid == best.holder.uuid]:
                st.waiters.remove(w)
                st.holders[w.holder.token] = w.holder
                w.granted = True
                w.wake.set()
        if st.holders or st.waiters or not st.preempted:
            return []
        resumes = sorted(st.preempted)
        st.preempted.clear()
        return resumes

    def _call_resume(self, uuids: list[str], resource: str) -> None:
        for uuid in uuids:
            log.info("resource %s free again: resuming pre-empted action %s", resource, uuid)
            self._resume(uuid, resource)
