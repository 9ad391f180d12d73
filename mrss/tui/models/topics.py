"""The Messages view's model: bus topics as a tree, each topic's latest messages and rate.

`count(envelopes, now)` is called by the dashboard's drain with each batch (cheap: a
dict lookup, two counters and a ring append per message); the tree, the rates and the
pretty JSON are made only when the Messages screen draws. A dotted topic is a path of
levels (`robot.uav1.data` is robot > uav1 > data); a node's count and rate are those of
every topic under it. The rate is messages per second over the last `WINDOW` seconds
(counted in one-second buckets; since the first message when that is more recent).
At most `MAX_TOPICS` topics are kept apart; messages on further topics are counted
under `OVERFLOW`. Pure Python: no Textual.
"""

from __future__ import annotations

import dataclasses
import json
import math
import time
from collections import deque
from collections.abc import Iterable
from dataclasses import dataclass, field
from typing import Any

from mrss.messages import Envelope, within_run

HISTORY = 50  # messages kept per topic
WINDOW = 10.0  # seconds of the rate's sliding window
MAX_TOPICS = 2000
OVERFLOW = "(other topics)"


@dataclass
class TopicStats:
    """One topic: messages seen, the newest `HISTORY`, per-second counts for the rate."""

    topic: str
    count: int = 0
    first: float = 0.0  # when its first message was counted
    recent: deque[Envelope] = field(default_factory=lambda: deque(maxlen=HISTORY))
    buckets: deque[list[int]] = field(default_factory=deque)  # [second, count], oldest first

    def add(self, env: Envelope, now: float) -> None:
        if not self.count:
            self.first = now
        self.count += 1
        self.recent.append(env)
        second = int(now)
        buckets = self.buckets
        if buckets and buckets[-1][0] == second:
            buckets[-1][1] += 1
        else:
            buckets.append([second, 1])
            while buckets and buckets[0][0] <= second - WINDOW:
                buckets.popleft()

    def in_window(self, now: float) -> int:
        """Messages counted in the last `WINDOW` seconds."""
        start = int(now) - WINDOW
        return sum(n for second, n in self.buckets if second > start)

    def rate(self, now: float) -> float:
        """Messages per second over the window (or since the first message, if later)."""
        span = min(WINDOW, max(1.0, now - self.first))
        return self.in_window(now) / span


@dataclass
class TopicNode:
    """A level of the tree: its name, full dotted path, totals of every topic below it."""

    name: str
    path: str
    count: int = 0
    rate: float = 0.0
    stats: TopicStats | None = None  # the topic itself, when one ends here
    children: dict[str, TopicNode] = field(default_factory=dict)

    def sorted_children(self) -> list[TopicNode]:
        return [self.children[name] for name in sorted(self.children)]

    def label(self) -> str:
        """`data  412 · 2.0/s`."""
        return f"{self.name}  {self.count} · {rate_text(self.rate)}"


def rate_text(rate: float) -> str:
    if rate >= 10:
        return f"{rate:.0f}/s"
    return f"{rate:.1f}/s"


class TopicsModel:
    """Every topic the dashboard received, with its latest messages and rate."""

    def __init__(self, clock: Any = time.monotonic) -> None:
        self.clock = clock
        self.topics: dict[str, TopicStats] = {}
        self.total = 0

    def count(self, envelopes: Iterable[Envelope], now: float | None = None) -> None:
        """Count a drained batch (all received at about `now`)."""
        when = self.clock() if now is None else now
        topics = self.topics
        for env in envelopes:
            stats = topics.get(env.topic)
            if stats is None:
                name = env.topic if len(topics) < MAX_TOPICS else OVERFLOW
                stats = topics.get(name)
                if stats is None:
                    stats = topics[name] = TopicStats(name)
            stats.add(env, when)
            self.total += 1

    def tree(self, now: float | None = None) -> TopicNode:
        """The topics as a tree of levels, with counts and rates summed upwards."""
        when = self.clock() if now is None else now
        root = TopicNode("bus", "")
        for name in sorted(self.topics):
            stats = self.topics[name]
            rate = stats.rate(when)
            node = root
            root.count += stats.count
            root.rate += rate
            parts = [name] if name == OVERFLOW else name.split(".")
            for i, part in enumerate(parts):
                path = ".".join(parts[: i + 1])
                child = node.children.get(part)
                if child is None:
                    child = node.children[part] = TopicNode(part, path)
                child.count += stats.count
                child.rate += rate
                node = child
            node.stats = stats
        return root

    def latest(self, topic: str) -> Envelope | None:
        stats = self.topics.get(topic)
        return stats.recent[-1] if stats and stats.recent else None

    def history(self, topic: str) -> list[Envelope]:
        """The topic's kept messages, newest first."""
        stats = self.topics.get(topic)
        return list(reversed(stats.recent)) if stats else []


def envelope_dict(env: Envelope) -> dict[str, Any]:
    """The decoded envelope as plain data: kind, src, inc, ts, id, body (and
    `replayed: true` for a message of `mrss replay`)."""
    body = env.body
    fields = ({f.name: getattr(body, f.name) for f in dataclasses.fields(body)}
              if dataclasses.is_dataclass(body) else dict(vars(body)))
    plain = {"topic": env.topic, "kind": env.kind, "src": env.src, "inc": env.inc,
             "ts": env.ts, "id": env.id, "body": fields}
    if env.replayed:
        plain["replayed"] = True
    return plain


def pretty_json(env: Envelope) -> str:
    """The envelope as indented JSON (values JSON cannot hold shown as text)."""
    return json.dumps(_plain(envelope_dict(env)), indent=2, ensure_ascii=False)


def _plain(value: Any) -> Any:
    if isinstance(value, dict):
        return {str(k): _plain(v) for k, v in value.items()}
    if isinstance(value, (list, tuple)):
        return [_plain(v) for v in value]
    if isinstance(value, float) and not math.isfinite(value):
        return str(value)
    if value is None or isinstance(value, (str, int, float, bool)):
        return value
    if isinstance(value, bytes):
        return f"<{len(value)} bytes>"
    return str(value)


def summary(env: Envelope, width: int = 100) -> str:
    """One line for the history: time, source, the body as compact JSON."""
    stamp = time.strftime("%H:%M:%S", time.localtime(env.ts)) + f".{int(env.ts * 1000) % 1000:03d}"
    body = json.dumps(_plain(envelope_dict(env)["body"]), ensure_ascii=False,
                      separators=(",", ":"))
    # a peer node's sender as its own root counts (the border ranks runs: docs/bus.md)
    line = f"{stamp} {env.src}#{within_run(env.inc)}{' (replayed)' if env.replayed else ''} {body}"
    return line if len(line) <= width else line[: width - 1] + "…"
