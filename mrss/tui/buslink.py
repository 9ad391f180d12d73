"""The TUI's connection to a running system's bus: an inbox filled by a subscriber thread.

Bus messages arrive on the subscriber's own thread, and Textual widgets may only be
touched from the app's thread. So the subscriber only appends to a deque and, when the
inbox goes from empty to non-empty, calls `wake` once (the app posts itself a message,
which is thread-safe). The app drains everything queued in one go: a burst of a
thousand statuses costs one redraw, not a thousand.
"""

from __future__ import annotations

import threading
from collections import deque
from collections.abc import Callable

from mrss.bus import BusEndpoints, Publisher, Stale, Subscriber
from mrss.edge.worldmodel_service import wm_reply_topic
from mrss.messages import Envelope, Message

# Everything the dashboard shows; `rel.action.` carries the reliable channel's requests.
# `percept` (hotspots found, for the alerts) and `edge.rejections` (the input each
# component refused); and the world model's answers to the dashboard's own `wm.list`
# (for the map), on `dl.reply.wm.<src>` (`wm_reply_topic`).
PREFIXES = ("action.", "rel.action.", "robot.", "sup.", "log.", "mind.", "ctl.", "percept",
            "edge.rejections")
INBOX_LIMIT = 100_000  # beyond this the oldest messages are dropped (`dropped` counts them)


class BusLink:
    """Subscribes to the dashboard's topics and publishes the operator's commands."""

    def __init__(self, endpoints: BusEndpoints, *, src: str = "tui",
                 prefixes: tuple[str, ...] = PREFIXES) -> None:
        self.endpoints = endpoints
        self.src = src
        self._prefixes = (*prefixes, wm_reply_topic(src))
        self._inbox: deque[Envelope] = deque()
        self._lock = threading.Lock()
        self._wake: Callable[[], object] = lambda: None
        self._woken = False
        self.dropped = 0
        self.received = 0
        self._sub: Subscriber | None = None
        self._pub: Publisher | None = None

    def start(self, wake: Callable[[], object]) -> None:
        """Connect; `wake()` is called (on the bus thread) when the inbox gets messages."""
        self._wake = wake
        self._pub = Publisher(self.endpoints, src=self.src)
        self._sub = Subscriber(self.endpoints, prefixes=self._prefixes, name=self.src,
                               stale=Stale.KEEP)  # an observer, across system restarts too
        self._sub.start(self._deliver)

    def _deliver(self, env: Envelope) -> None:
        with self._lock:
            self.received += 1
            if len(self._inbox) >= INBOX_LIMIT:
                self._inbox.popleft()
                self.dropped += 1
            self._inbox.append(env)
            if self._woken:
                return
            self._woken = True
        self._wake()

    def drain(self) -> list[Envelope]:
        """Everything received since the last drain, oldest first."""
        with self._lock:
            items = list(self._inbox)
            self._inbox.clear()
            self._woken = False
        return items

    @property
    def connected(self) -> bool:
        """Whether the proxy has greeted the subscriber (its topics are subscribed)."""
        return self._sub is not None and self._sub.wait_connected(timeout=0)

    @property
    def welcomes(self) -> int:
        """How many times the proxy greeted the subscriber: it grows after a proxy restart."""
        return self._sub.welcomes if self._sub is not None else 0

    def publish(self, msg: Message, topic: str | None = None) -> str:
        """Send one operator message (on `topic`, default its own); its id."""
        if self._pub is None:
            raise RuntimeError("the bus link is not started")
        return self._pub.publish(msg, topic=topic)

    def close(self) -> None:
        if self._sub is not None:
            self._sub.close()
        if self._pub is not None:
            self._pub.close()
