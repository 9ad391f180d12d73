"""Direct delivery: messages go from publisher to subscriber, the proxy only introduces them.

With `[bus] delivery = "direct"` the proxy forwards no messages. The rules:

1. A subscriber is a *member*: its SUB socket binds an endpoint of its own (ipc: a file
   `bus-m-<pid>-<n>.sock` beside the proxy's sockets; tcp: a free port on the proxy's
   host) and subscribes, besides its prefixes, its *membership topic* `MEMBER` +
   msgpack([endpoint, prefixes, pid]). It still connects to the proxy, so its
   subscriptions, membership included, reach the proxy and through it every publisher.
2. The direct proxy subscribes its publishers to `MARKER` only (never to everything),
   once its clients had time to reconnect after its start, and passes every subscription
   on except `""`. A publisher whose proxy subscribed `MARKER` delivers directly; one
   whose proxy subscribed `""` sends through the proxy as before. ZeroMQ replays a
   proxy's subscriptions to each new publisher in byte order, so `MARKER` comes after
   every membership: a publisher that has seen it knows all members.
3. A publisher connects a socket of its own to each member's endpoint; the member has
   *joined* when its membership topic comes back on that socket (a SUB sends its
   subscriptions in byte order too, so all of them are in by then). Until then the
   publisher holds every message that member wants (and, for order, all that follow),
   at most `PATIENCE` seconds; before `MARKER` it holds everything (first words).
4. A member is gone when the proxy withdraws its membership (it left the proxy: closed
   or died) or when its process is gone (publishers look every `SWEEP` seconds): the
   publisher disconnects. A proxy that dies withdraws nothing (ZeroMQ keeps a connecting
   socket's subscriptions for its reconnection), so the direct links carry on.
5. The proxy answers each new membership with one frame `[membership topic]` on its
   backend once every publisher it knows has joined the member (mrss/bus/introducer.py):
   the member's `wait_connected` waits for it, so what is published after it returns
   reaches the member.
   A member binds when it is made (`BusEndpoints(direct=True)`), or when the proxy's
   welcome says the bus is direct (`WELCOME_DIRECT`) to a subscriber not told so.
6. A member's ipc file is removed when it closes; files of members whose process is
   gone are removed by the next member that binds there.
7. A member's socket takes in a publisher's connection only when its thread touches it;
   a keeper thread per process touches idle members' sockets every `KEEP` seconds, so
   a member that nobody reads at the moment still joins.

Direct delivery is for one host (ipc, or tcp on a loopback address) without `[nodes]`.
"""

from __future__ import annotations

import itertools
import os
import threading
import time
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path

import msgpack
import zmq

from mrss.bus import sockets
from mrss.bus.endpoints import BusEndpoints
from mrss.bus.wire import MARKER, MEMBER, WELCOME_DIRECT

__all__ = ["MARKER", "MEMBER", "PATIENCE", "WELCOME_DIRECT", "Membership", "bind_member",
           "forget_member", "membership_topic", "read_membership"]
PATIENCE = 2.0  # seconds a publisher holds messages for a member that has not joined
SWEEP = 1.0  # seconds between a publisher's looks for members whose process is gone
KEEP = 0.02  # seconds between the keeper's touches of idle members' sockets
_FILE_PREFIX = "bus-m-"
_counter = itertools.count()


@dataclass(frozen=True)
class Membership:
    """A member's endpoint and the topic prefixes it takes, as its membership topic says."""

    topic: bytes
    endpoint: str
    prefixes: tuple[bytes, ...]
    pid: int

    def wants(self, topic: bytes) -> bool:
        return any(topic.startswith(prefix) for prefix in self.prefixes)


def membership_topic(endpoint: str, prefixes: tuple[bytes, ...]) -> bytes:
    packed: bytes = msgpack.packb([endpoint, list(prefixes), os.getpid()], use_bin_type=True)
    return MEMBER + packed


def read_membership(topic: bytes) -> Membership | None:
    """The membership a topic states; None (to ignore) if it is not a well-formed one."""
    try:
        endpoint, prefixes, pid = msgpack.unpackb(topic[1:], raw=False)
        ok = isinstance(endpoint, str) and endpoint.startswith(("ipc://", "tcp://", "inproc://")) \
            and isinstance(prefixes, list) and all(isinstance(p, bytes) for p in prefixes) \
            and isinstance(pid, int) and pid > 0
    except (ValueError, TypeError, msgpack.ExtraData, msgpack.FormatError,
            msgpack.StackError):
        return None
    return Membership(topic, endpoint, tuple(prefixes), pid) if ok else None


def bind_member(sock: sockets.Socket, endpoints: BusEndpoints) -> str:
    """Bind `sock` (a SUB) to an endpoint of its own beside the proxy's; return it."""
    backend = endpoints.backend
    if backend.startswith("ipc://"):
        folder = Path(backend[len("ipc://"):]).parent
        _remove_dead_members(folder)
        endpoint = f"ipc://{folder / f'{_FILE_PREFIX}{os.getpid()}-{next(_counter)}.sock'}"
        sock.bind(endpoint)
        return endpoint
    if backend.startswith("tcp://"):
        host = backend[len("tcp://"):].rpartition(":")[0]
        sock.bind(f"tcp://{'127.0.0.1' if host in ('*', '0.0.0.0') else host}:*")
        return str(sock.getsockopt_string(zmq.LAST_ENDPOINT))
    endpoint = f"inproc://mrss-member-{os.getpid()}-{next(_counter)}"
    sock.bind(endpoint)
    return endpoint


def subscriber_socket(ctx: sockets.Context, endpoints: BusEndpoints, topics: list[bytes], *,
                      hwm: int = sockets.DEFAULT_HWM) -> tuple[sockets.Socket, str | None]:
    """A SUB on the bus for `topics`, a member with its endpoint on a direct bus (rule 1),
    for the parts that read their socket themselves; `forget_member(endpoint)` after
    closing it."""
    sock = sockets.connect(ctx, zmq.SUB, endpoints.backend, hwm=hwm)
    for topic in topics:
        sock.setsockopt(zmq.SUBSCRIBE, topic)
    if not endpoints.direct:
        return sock, None
    try:
        return sock, become_member(sock, endpoints, topics)
    except zmq.ZMQError:
        sock.close(0)
        raise


def become_member(sock: sockets.Socket, endpoints: BusEndpoints, topics: list[bytes]) -> str:
    """Bind `sock` (a SUB already subscribed to `topics`) as a member and announce it;
    its endpoint. For a socket made for a plain bus that the welcome says is direct."""
    endpoint = bind_member(sock, endpoints)
    sock.setsockopt(zmq.SUBSCRIBE, membership_topic(endpoint, tuple(topics)))
    return endpoint


def forget_member(endpoint: str | None) -> None:
    """Remove a closed member's ipc file."""
    if endpoint is None:
        return
    for path in BusEndpoints.paths_of([endpoint]):
        path.unlink(missing_ok=True)


def _remove_dead_members(folder: Path) -> None:
    try:
        names = [p for p in folder.glob(f"{_FILE_PREFIX}*.sock")]
    except OSError:
        return
    for path in names:
        pid = path.name[len(_FILE_PREFIX):].split("-", 1)[0]
        if pid.isdigit() and not alive(int(pid)):
            path.unlink(missing_ok=True)


class Keeper:
    """Rule 7: touches the sockets of this process's members while their owners do not.

    A member registers `touch`, a callable that takes its lock without waiting (an owner
    that holds it is receiving, which does the same) and lets ZeroMQ take in waiting
    connections; the thread runs while any member is registered.
    """

    def __init__(self) -> None:
        self._lock = threading.Lock()
        self._touches: dict[int, Callable[[], None]] = {}
        self._thread: threading.Thread | None = None

    def add(self, key: int, touch: Callable[[], None]) -> None:
        with self._lock:
            self._touches[key] = touch
            if self._thread is None:
                self._thread = threading.Thread(target=self._run, name="mrss-bus-keeper",
                                                daemon=True)
                self._thread.start()

    def remove(self, key: int) -> None:
        with self._lock:
            self._touches.pop(key, None)

    def _run(self) -> None:
        while True:
            time.sleep(KEEP)
            with self._lock:
                touches = list(self._touches.values())
                if not touches:
                    self._thread = None
                    return
            for touch in touches:
                touch()


KEEPER = Keeper()


def alive(pid: int) -> bool:
    """Whether a process of this id exists (on this host)."""
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return False
    except PermissionError:
        return True
    return True
