"""Helpers for the dashboard tests: an async condition wait and a bus peer.

Textual's pilot runs the app on the test's asyncio loop, so conditions are awaited with
`until` (the async twin of mrss.testing.wait_until: it yields to the app between polls).
"""

from __future__ import annotations

import asyncio
import threading
import time
from collections.abc import Callable
from typing import Any, TypeVar

from textual.pilot import Pilot

from mrss.bus import BusEndpoints, Publisher, Subscriber
from mrss.messages import Envelope, Heartbeat, Message
from mrss.testing import WaitTimeout, expired
from mrss.tui.confirm import ConfirmScreen

T = TypeVar("T")
M = TypeVar("M", bound=Message)


async def until(pilot: Pilot[Any], condition: Callable[[], T], timeout: float = 10.0,
                message: str = "condition", describe: Callable[[], str] | None = None) -> T:
    """Poll `condition`, letting the app run between polls, until it is truthy; return it.
    On a timeout `describe()` (if given) says what was there instead."""
    started = time.monotonic()
    while True:
        value = condition()
        if value:
            return value
        if time.monotonic() - started >= timeout and expired(started, timeout):
            seen = f"; instead: {describe()}" if describe is not None else ""
            raise WaitTimeout(f"{message} did not hold within {timeout:.1f}s{seen}")
        await pilot.pause(0.01)


async def confirmed(pilot: Pilot[Any], *keys: str, answer: str = "y") -> None:
    """Press `keys`, wait for the question they raise (ConfirmScreen), answer it. The
    answer is pressed only once the question is up: pressed at once, on a loaded
    machine it can reach the panel before the screen is mounted, and be lost."""
    await pilot.press(*keys)
    await until(pilot, lambda: isinstance(pilot.app.screen, ConfirmScreen),
                message=f"the question of {' '.join(keys)}")
    await pilot.press(answer)


class Peer:
    """The rest of the system, as the test plays it: publishes, and records what arrives."""

    def __init__(self, endpoints: BusEndpoints) -> None:
        self.pub = Publisher(endpoints, src="supervisor")
        self.sub = Subscriber(endpoints, prefixes=["percept", "action.control", "ctl."])
        self._lock = threading.Lock()
        self._seen: list[Envelope] = []
        self.sub.start(self._keep)
        assert self.sub.wait_connected(10), "peer subscriber not connected"
        assert self.pub.wait_connected(10), "peer publisher not connected"

    def _keep(self, env: Envelope) -> None:
        with self._lock:
            self._seen.append(env)

    def publish(self, msg: Message, src: str | None = None) -> None:
        if src is None:
            self.pub.publish(msg)
        else:
            with Publisher(self.pub.endpoints, src=src) as other:
                assert other.wait_connected(10)
                other.publish(msg)
                other.flush()

    def received(self, kind: type[M], *, src: str = "tui") -> list[M]:
        """The messages of `kind` received so far from `src`."""
        with self._lock:
            return [e.body for e in self._seen if isinstance(e.body, kind) and e.src == src]

    def close(self) -> None:
        self.sub.close()
        self.pub.close()


def run(coro: Any) -> Any:
    """Run one async test body (no pytest-asyncio needed)."""
    return asyncio.run(coro)


def row_text(table: Any, key: str) -> list[str]:
    """The plain text of a table row's cells."""
    return [cell.plain for cell in table.get_row(key)]


def has_row(table: Any, key: str) -> bool:
    return key in table.shown_keys()


async def connected(pilot: Pilot[Any], peer: Peer) -> None:
    """Wait until messages from `peer` reach the app's subscriber.

    The proxy's welcome only says the subscriber is connected; its topic subscriptions
    may still be on their way, so probe with a heartbeat (shown nowhere) until one
    arrives.
    """
    app: Any = pilot.app
    await until(pilot, lambda: app.link.connected, message="the TUI's bus subscriber connected")
    deadline = time.monotonic() + 10.0
    while app.link.received == 0:
        peer.publish(Heartbeat(component="probe", pid=0))
        if time.monotonic() > deadline:
            raise WaitTimeout("no probe reached the TUI")
        for _ in range(20):
            await pilot.pause(0.01)
            if app.link.received:
                break
