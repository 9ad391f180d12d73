"""Supervision events: published on `sup.<event>` through an injected callable, and logged.

The publish callable is `mrss.bus.Publisher.publish` in a running system; anything that
accepts a `SupEvent` works (tests collect them in an `EventLog`). A failing publisher is
logged and never takes the supervisor down.
"""

from __future__ import annotations

import logging
import os
import threading
import time
from collections.abc import Callable
from typing import Any

from mrss.messages import Message, SupEvent, SupEventKind

Publish = Callable[[Message], object]
NODE_ENV = "MRSS_NODE"

# The event names a supervisor emits (SupEvent.event).
START = SupEventKind.START
EXIT = SupEventKind.EXIT
RESTART = SupEventKind.RESTART
ESCALATE = SupEventKind.ESCALATE
GIVE_UP = SupEventKind.GIVE_UP
QUARANTINE = SupEventKind.QUARANTINE
RELEASE = SupEventKind.RELEASE
HANG = SupEventKind.HANG
STOPPING = SupEventKind.STOPPING  # the supervisor begins to stop every child (child: itself)


class SupEvents:
    """Emits one supervisor's events: builds the SupEvent, logs one line, publishes it."""

    def __init__(
        self, supervisor: str, publish: Publish | None = None,
        logger: logging.Logger | None = None, node: str | None = None,
    ) -> None:
        self.supervisor = supervisor
        # The node this runs on (`mrss supervise --node` sets MRSS_NODE for the whole
        # tree, components included); "" on a single host.
        self.node = os.environ.get(NODE_ENV, "") if node is None else node
        self._publish = publish
        self._log = logger or logging.getLogger(f"mrss.supervision.{supervisor}")

    def child(self, name: str) -> SupEvents:
        """The emitter of a nested supervisor `name`, sharing this one's publisher."""
        return SupEvents(f"{self.supervisor}/{name}", self._publish, self._log, self.node)

    def emit(
        self, event: SupEventKind, child: str, *, pid: int = 0, reason: str = "", count: int = 0,
        **detail: Any,
    ) -> SupEvent:
        msg = SupEvent(event=event, child=child, supervisor=self.supervisor, pid=pid,
                       reason=reason, count=count, detail=detail, node=self.node)
        level = logging.INFO if event in (START, RESTART, RELEASE) else logging.WARNING
        if event == EXIT and reason.startswith("shutdown"):
            level = logging.INFO
        # (an incarnation's credential is for receivers, not for a reader of the log)
        extras = " ".join(f"{k}={v}" for k, v in detail.items() if k != "cred")
        self._log.log(level, "%s %s%s%s%s%s", event, child, f" pid={pid}" if pid else "",
                      f" count={count}" if count else "", f" reason={reason!r}" if reason else "",
                      f" {extras}" if extras else "")
        if self._publish is not None:
            try:
                self._publish(msg)
            except Exception:  # a broken bus must not break supervision
                self._log.exception("cannot publish sup.%s for %s", event, child)
        return msg


class EventLog:
    """A publish callable that keeps every SupEvent, for tests and benchmarks."""

    def __init__(self) -> None:
        self._lock = threading.Lock()
        self._events: list[tuple[float, SupEvent]] = []

    def __call__(self, msg: Message) -> None:
        if isinstance(msg, SupEvent):
            with self._lock:
                self._events.append((time.monotonic(), msg))

    @property
    def events(self) -> list[SupEvent]:
        with self._lock:
            return [e for _, e in self._events]

    def timed(self) -> list[tuple[float, SupEvent]]:
        with self._lock:
            return list(self._events)

    def of(self, event: str, child: str | None = None) -> list[SupEvent]:
        return [e for e in self.events
                if e.event == event and (child is None or e.child == child)]

    def wait_for(
        self, event: str, child: str | None = None, count: int = 1, timeout: float = 10.0,
    ) -> list[SupEvent]:
        """Wait until at least `count` such events were seen; return them."""
        from mrss.testing import wait_until

        def enough() -> list[SupEvent]:
            found = self.of(event, child)
            return found if len(found) >= count else []

        return wait_until(enough, timeout=timeout,
                          message=f"{count} sup.{event} event(s) for {child or 'any child'}")
