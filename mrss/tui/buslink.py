"""The TUI's connection to a running system's bus: read on the app's own event loop.

The subscriber's socket is a reader of the app's asyncio loop, not a thread: a message
wakes the loop directly, and nothing wakes while nothing comes (a receiving thread
looked for `close()` twenty times a second, which was most of an idle dashboard's CPU).
What arrives goes to an inbox and, when the inbox goes from empty to non-empty, `wake`
is called once (the app posts itself a message). The app drains everything queued in
one go: a burst of a thousand statuses costs one redraw, not a thousand. After a read
the socket is not watched for `READ_EVERY` seconds: what comes meanwhile waits in it
(its high-water mark is 10,000 messages) and is taken in one go then, or by a drain
that comes first; not one wake of the loop per message (each was a wake, a read and a
decode on cold caches: `mrss bench tui` at 1,000 msgs/s, 20 % of a core against 11 %).
"""

from __future__ import annotations

import asyncio
from collections import deque
from collections.abc import Callable

from mrss.bus import BusEndpoints, Publisher, Stale, Subscriber
from mrss.messages import Envelope, Message
from mrss.world.topics import wm_reply_topic

# Everything the dashboard shows; `rel.action.` carries the reliable channel's requests.
# `percept` (hotspots found, for the alerts), `edge.rejections` (the input each
# component refused) and `agent.` (goals the agent gave up: `GoalGaveUp`); and the
# world model's answers to the dashboard's own `wm.list` (for the map), on
# `dl.reply.wm.<src>` (`wm_reply_topic`); the agent's questions and the replies to
# answers (`question.`).
PREFIXES = ("action.", "rel.action.", "robot.", "sup.", "log.", "mind.", "ctl.", "percept",
            "edge.rejections", "agent.", "question.", "fleet.")
INBOX_LIMIT = 100_000  # beyond this the oldest messages are dropped (`dropped` counts them)
BATCH = 2_000  # messages taken per turn of the loop
READ_EVERY = 0.1  # seconds: after a read, the socket is read again at the earliest then


class BusLink:
    """Subscribes to the dashboard's topics and publishes the operator's commands."""

    def __init__(self, endpoints: BusEndpoints, *, src: str = "tui",
                 prefixes: tuple[str, ...] = PREFIXES) -> None:
        self.endpoints = endpoints
        self.src = src
        self.operator = ""  # the session credential sent with each message (mrss.auth)
        self._prefixes = (*prefixes, wm_reply_topic(src))
        self._inbox: deque[Envelope] = deque(maxlen=INBOX_LIMIT)  # drops the oldest
        self._loop: asyncio.AbstractEventLoop | None = None
        self._wake: Callable[[], object] = lambda: None
        self._woken = False
        self._watching = False  # the loop calls `poll` when the socket is readable
        self.dropped = 0
        self.received = 0
        self._sub: Subscriber | None = None
        self._pub: Publisher | None = None

    def start(self, wake: Callable[[], object]) -> None:
        """Connect, on the running event loop; `wake()` is called when the inbox gets
        messages."""
        self._wake = wake
        self._pub = Publisher(self.endpoints, src=self.src)
        self._sub = Subscriber(self.endpoints, prefixes=self._prefixes, name=self.src,
                               stale=Stale.KEEP)  # an observer, across system restarts too
        self._loop = asyncio.get_running_loop()
        self._watch(True)
        self.poll()  # the descriptor is edge-triggered: take what came before

    def poll(self) -> None:
        """Take every message waiting on the socket into the inbox.

        Called by the loop when the socket is readable; the app also calls it now and
        then, so a missed edge costs a moment, never a message.
        """
        if self._sub is None:
            return
        envelopes = self._sub.take_ready(BATCH)
        if not envelopes:
            return
        self._keep(envelopes)
        if not self._woken:
            self._woken = True
            self._wake()
        if self._loop is None:
            return
        if len(envelopes) == BATCH:
            self._loop.call_soon(self.poll)  # more waiting: the loop serves others between
        elif self._watching:  # the next read in a while
            self._watch(False)
            self._loop.call_later(READ_EVERY, self._resume)

    def _keep(self, envelopes: list[Envelope]) -> None:
        self.received += len(envelopes)
        self.dropped += max(0, len(self._inbox) + len(envelopes) - INBOX_LIMIT)
        self._inbox.extend(envelopes)

    def _resume(self) -> None:
        self._watch(True)
        self.poll()  # edge-triggered: what came while it was not watched

    def drain(self) -> list[Envelope]:
        """Everything received since the last drain, oldest first, with what waits on
        the socket while it is not watched (at most `READ_EVERY` of it)."""
        while not self._watching and self._sub is not None:
            waiting = self._sub.take_ready(BATCH)
            self._keep(waiting)
            if len(waiting) < BATCH:
                break
        items = list(self._inbox)
        self._inbox.clear()
        self._woken = False
        return items

    def _watch(self, on: bool) -> None:
        """Have the loop call `poll` when the socket is readable (or not)."""
        if self._sub is None or self._loop is None or self._loop.is_closed() \
                or on == self._watching:
            return
        self._watching = on
        if on:
            self._loop.add_reader(self._sub.fileno(), self.poll)
        else:
            self._loop.remove_reader(self._sub.fileno())

    @property
    def connected(self) -> bool:
        """Whether the proxy has greeted the subscriber (its topics are subscribed)."""
        return self._sub is not None and self._sub.wait_connected(timeout=0)

    @property
    def welcomes(self) -> int:
        """How many times the proxy greeted the subscriber: it grows after a proxy restart."""
        return self._sub.welcomes if self._sub is not None else 0

    def where(self) -> str:
        """What the header says the dashboard is looking at."""
        return f"connected · {self.endpoints.backend}"

    def publish(self, msg: Message, topic: str | None = None) -> str:
        """Send one operator message (on `topic`, default its own), with the logged-in
        operator's session credential (`operator`); its id."""
        if self._pub is None:
            raise RuntimeError("the bus link is not started")
        self._pub.operator = self.operator
        return self._pub.publish(msg, topic=topic)

    def close(self) -> None:
        if self._sub is not None:
            self._watch(False)
            self._loop = None
            self._sub.close()  # take_ready now returns nothing
        if self._pub is not None:
            self._pub.close()
