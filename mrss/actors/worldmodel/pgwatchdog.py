"""The PostGIS store's request deadline: a watchdog thread that cuts a connection whose
request runs too long (a frozen server or network), so the blocked call fails."""

from __future__ import annotations

import os
import socket
import threading
import time
from typing import Any

import psycopg


class Watchdog:
    """One thread per store that cuts the connection of a request running past its
    deadline (a frozen server or network): the blocked call then fails instead of
    waiting for ever. `arm` before a request, `disarm` after it."""

    def __init__(self, timeout: float) -> None:
        self.timeout = timeout
        self.fired = False
        self._cond = threading.Condition()
        self._conn: psycopg.Connection[Any] | None = None
        self._deadline: float | None = None
        self._idle = False
        self._closed = False
        self._thread: threading.Thread | None = None

    def arm(self, conn: psycopg.Connection[Any]) -> None:
        """A request on `conn` starts now."""
        with self._cond:
            self._conn, self.fired = conn, False
            self._deadline = time.monotonic() + self.timeout
            if self._thread is None:
                self._thread = threading.Thread(target=self._watch, daemon=True,
                                                name="worldmodel-pg-watchdog")
                self._thread.start()
            elif self._idle:
                self._cond.notify()

    def disarm(self) -> None:
        """The request is over."""
        with self._cond:
            self._conn, self._deadline = None, None

    def close(self) -> None:
        """Stop the thread."""
        with self._cond:
            self._closed = True
            self._cond.notify()

    def _watch(self) -> None:
        with self._cond:
            while not self._closed:
                if self._deadline is None:
                    self._idle = True
                    self._cond.wait()
                    self._idle = False
                    continue
                left = self._deadline - time.monotonic()
                if left > 0:
                    self._cond.wait(left)
                    continue
                self._deadline, self.fired = None, True
                if self._conn is not None:
                    _cut(self._conn)


def _cut(conn: psycopg.Connection[Any]) -> None:
    """Shut the connection's socket down under libpq: its blocked call returns an error."""
    try:
        with socket.socket(fileno=os.dup(conn.pgconn.socket)) as sock:
            sock.shutdown(socket.SHUT_RDWR)
    except (OSError, psycopg.Error):
        pass
