"""Calling the data layer over the bus: a request, the reply with the same request id.

    client = DataLayerClient(bus)
    reply = client.request("ground", ["h1"], timeout=2.0)   # a DataReply, never raises
    value = client.call("ground", ["h1"], timeout=2.0)      # the result, or DataLayerError
    client.send("wm.upsert", [obj])                         # no waiting (telemetry writes)

The reasoner's `query(...)` and the RCL's grounding use `call`. A reply that never comes
becomes an error reply (`ok=False`) after the timeout (`call` raises
`DataLayerUnavailable` then: the data layer may be restarting, so an edge event that
needed it is retried); replies to unknown or expired requests are ignored.
"""

from __future__ import annotations

import logging
import threading
import time
from collections.abc import Sequence
from typing import Any

from mrss.edge.retry import DependencyUnavailable
from mrss.errors import MrssError
from mrss.messages import DataReply, DataRequest, Envelope, Topic, new_id
from mrss.runtime.busport import BusPort

DEFAULT_TIMEOUT = 5.0
NO_WAIT = "nowait-"  # request ids of `send`: nobody waits for their replies
log = logging.getLogger("mrss.datalayer")


class DataLayerError(MrssError):
    """A data layer call failed: the function raised, was unknown, or timed out."""

    def __init__(self, function: str, reason: str, *, request_id: str = "") -> None:
        self.function = function
        self.reason = reason
        self.request_id = request_id
        super().__init__(f"data layer call {function!r} failed: {reason}")


class DataLayerUnavailable(DataLayerError, DependencyUnavailable):
    """No reply came within the timeout (the data layer or the bus is down or busy), or
    the reply says the function's own dependency was (`DataReply.transient`)."""


class _Pending:
    __slots__ = ("done", "reply")

    def __init__(self) -> None:
        self.done = threading.Event()
        self.reply: DataReply | None = None


class DataLayerClient:
    """Request/reply over pub/sub, matched by request id; thread-safe."""

    def __init__(self, bus: BusPort, *, request_topic: str = Topic.DL_REQUEST.value,
                 reply_topic: str = Topic.DL_REPLY.value,
                 default_timeout: float = DEFAULT_TIMEOUT) -> None:
        self._bus = bus
        self.request_topic = request_topic
        self.reply_topic = reply_topic
        self.default_timeout = default_timeout
        self._pending: dict[str, _Pending] = {}
        self._lock = threading.Lock()
        self.unmatched_replies = 0
        self.failed_sends = 0
        self.answered_sends = 0  # replies to `send`s (every one, tracked or not)
        self._tracked: dict[str, threading.Event] = {}  # `send(track=True)` not answered
        self._send_logged = -60.0
        self._sub = bus.subscribe([reply_topic], self._on_reply)

    def close(self) -> None:
        """Stop listening; requests still waiting time out."""
        self._sub.close()

    def request(self, function: str, args: Sequence[Any] = (),
                timeout: float | None = None) -> DataReply:
        """Send a request and wait for its reply; a timeout gives an error reply."""
        return self._exchange(function, args, timeout)[0]

    def call(self, function: str, args: Sequence[Any] = (),
             timeout: float | None = None) -> Any:
        """The result of `function(*args)`, or DataLayerError with the reason
        (DataLayerUnavailable when no reply came in time, or the reply says the error is
        transient: the function's own dependency, the world model, was away)."""
        reply, answered = self._exchange(function, args, timeout)
        if not reply.ok:
            kind = DataLayerError if answered and not reply.transient \
                else DataLayerUnavailable
            raise kind(function, reply.error or "error reply", request_id=reply.request_id)
        return reply.result

    def send(self, function: str, args: Sequence[Any] = (), *, track: bool = False) -> str:
        """Send a request without waiting for its reply (requests of one client are
        handled in the order sent); its request id. An error reply is counted in
        `failed_sends` and logged, at most once a minute. With `track`, `wait_answered`
        can wait for its reply (it must be called once for that id)."""
        request_id = NO_WAIT + new_id()
        if track:
            with self._lock:
                self._tracked[request_id] = threading.Event()
        self._bus.publish(DataRequest(request_id=request_id, function=function,
                                      args=list(args)), topic=self.request_topic)
        return request_id

    def wait_answered(self, request_id: str, timeout: float) -> bool:
        """Wait until the reply to a `send(track=True)` came; False after `timeout`
        (the id is forgotten either way)."""
        with self._lock:
            answered = self._tracked.get(request_id)
        try:
            return answered is not None and answered.wait(timeout)
        finally:
            with self._lock:
                self._tracked.pop(request_id, None)

    def _exchange(self, function: str, args: Sequence[Any],
                  timeout: float | None) -> tuple[DataReply, bool]:
        """The reply, and whether it came from the data layer (False: timed out)."""
        request_id = new_id()
        waiter = _Pending()
        with self._lock:
            self._pending[request_id] = waiter
        limit = self.default_timeout if timeout is None else timeout
        try:
            self._bus.publish(DataRequest(request_id=request_id, function=function,
                                          args=list(args)), topic=self.request_topic)
            if waiter.done.wait(limit) and waiter.reply is not None:
                return waiter.reply, True
            return DataReply(request_id=request_id, ok=False,
                             error=f"no reply to {function!r} within {limit:g}s"), False
        finally:
            with self._lock:
                self._pending.pop(request_id, None)

    def _on_reply(self, env: Envelope) -> None:
        body = env.body
        if env.topic != self.reply_topic or not isinstance(body, DataReply):
            return
        if body.request_id.startswith(NO_WAIT):
            with self._lock:
                self.answered_sends += 1
                answered = self._tracked.get(body.request_id)
            if answered is not None:
                answered.set()
            failed = [body.error] if not body.ok else _entry_errors(body.result)
            if failed:
                self.failed_sends += len(failed)
                now = time.monotonic()
                if now - self._send_logged >= 60.0:
                    self._send_logged = now
                    log.warning("a request sent without waiting failed (%d so far): %s",
                                self.failed_sends, failed[0])
            return
        with self._lock:
            waiter = self._pending.get(body.request_id)
        if waiter is None:
            self.unmatched_replies += 1
            return
        waiter.reply = body
        waiter.done.set()


def _entry_errors(result: Any) -> list[str]:
    """The errors of a batch's reply (a list with {"error": text} for refused entries)."""
    if not isinstance(result, list):
        return []
    return [str(r["error"]) for r in result if isinstance(r, dict) and "error" in r]
