"""The root supervisor's event loop plumbing: a selector plus a wake-up pipe.

Readable descriptors are registered with a callable as their key data; other threads
(and signal handlers) hand work to the loop thread with `submit`, which never blocks.
"""

from __future__ import annotations

import os
import selectors
from collections import deque
from collections.abc import Callable
from typing import Any

Callback = Callable[[], None]


class EventLoop:
    """Waits for readable descriptors or submitted commands; runs their callbacks."""

    def __init__(self) -> None:
        self.selector = selectors.DefaultSelector()
        self._commands: deque[Callback] = deque()
        self._wake_r, self._wake_w = os.pipe()
        os.set_blocking(self._wake_r, False)
        os.set_blocking(self._wake_w, False)
        self.selector.register(self._wake_r, selectors.EVENT_READ, self._drain)

    def register(self, fileobj: Any, callback: Callback) -> None:
        self.selector.register(fileobj, selectors.EVENT_READ, callback)

    def unregister(self, fileobj: Any) -> None:
        try:
            self.selector.unregister(fileobj)
        except (KeyError, ValueError):
            pass

    def submit(self, command: Callback) -> None:
        """Run `command` on the loop thread soon (safe from any thread or signal handler)."""
        self._commands.append(command)
        try:
            os.write(self._wake_w, b"x")
        except OSError:
            pass  # the pipe is full (the loop is awake anyway) or closed (loop ended)

    def wait(self, timeout: float) -> list[Callback]:
        """Block up to `timeout` seconds; the callbacks of what became ready."""
        return [key.data for key, _ in self.selector.select(timeout)]

    def _drain(self) -> None:
        try:
            while os.read(self._wake_r, 4096):
                pass
        except BlockingIOError:
            pass
        while self._commands:
            self._commands.popleft()()

    def close(self) -> None:
        self.selector.close()
        os.close(self._wake_r)
        os.close(self._wake_w)
