"""Relays with real sockets in a robot's path, which delay, lose, reorder or cut traffic.

A campaign's network faults on one host need something in the path: the components of
one node talk over unix sockets, and the kernel's netem (`tc qdisc ... netem`), which
would delay, lose and reorder packets on the wire, is not in every kernel (not in the
one MRSS's CI runs on: CONFIG_NET_SCH_NETEM is off, "Specified qdisc kind is unknown").
So a relay stands where a robot's link goes (mrss.config.detours): real UDP datagrams
and real TCP bytes pass through it, and its `Impairments` decide what becomes of them.

- `UdpRelay` (a MAVLink link): every datagram either way may be dropped (`partition`:
  all; `loss`: each with its probability), held back `delay` s, or held back a further
  `REORDER_HOLD` s with the `reorder` probability, so the ones after it overtake it.
  The upstream (the simulator's UDP port) is read again whenever its address file
  changes: a restarted simulator is found.
- `TcpRelay` (an MQTT robot and its broker): each connection gets its own upstream
  connection; bytes either way are held `delay` s, and not forwarded at all while
  `partition` is on (they wait in the relay and the sockets' buffers, as segments a
  cut network makes the sender retransmit): once healed they flow again, unless an
  end gave up meanwhile (an MQTT keepalive expired) and closed its connection, which
  the relay then closes on the other side too. TCP hides packet loss from its ends:
  what they see of a lossy link is stalls (a lost segment waits for its retransmission
  timeout, doubled at each loss again) and, when retransmissions give up or a middlebox
  resets, a dropped connection. So `loss` on a TCP relay is that, and not lost bytes:
  each chunk of bytes either way is, with the loss probability, stalled `stall` s
  (LOSS_STALL) before it passes, and with `reset_share` of that probability the
  connection is reset instead (RST to both ends; the MQTT client reconnects, through
  the relay again). Bytes that pass are intact and in order. `reorder` does not apply.

Faults overlap: each one adds its impairment and its heal removes it again; what
applies is the strongest of those on (any partition, the highest loss, the longest
delay). Decisions are drawn from a seeded generator.
"""

from __future__ import annotations

import heapq
import random
import selectors
import socket
import struct
import threading
import time
from collections import Counter
from collections.abc import Callable
from dataclasses import dataclass, field
from enum import StrEnum
from typing import Self

Address = tuple[str, int]
Upstream = Callable[[], Address | None]
REORDER_HOLD = 0.15  # s a datagram picked for reordering is held back (others overtake)
LOSS_STALL = 1.0  # s a TCP chunk hit by `loss` is stalled (an initial retransmission timeout)
RESET_SHARE = 0.1  # of the chunks hit by `loss`, the share whose connection is reset
DATAGRAM = 65535
CHUNK = 65536
TICK = 0.05


class Impairment(StrEnum):
    """What a network fault does to what passes the relay."""

    PARTITION = "partition"  # nothing passes
    LOSS = "loss"            # each datagram dropped with probability `amount`
    DELAY = "delay"          # everything held `amount` s
    REORDER = "reorder"      # each datagram held REORDER_HOLD s more with probability `amount`


@dataclass
class Impairments:
    """The impairments on now; thread-safe; overlapping ones held by a count each."""

    seed: int = 0
    _on: list[tuple[Impairment, float]] = field(default_factory=list)
    _lock: threading.Lock = field(default_factory=threading.Lock)
    _rng: random.Random = field(init=False)

    def __post_init__(self) -> None:
        self._rng = random.Random(self.seed)

    def add(self, kind: Impairment, amount: float = 0.0) -> Callable[[], None]:
        """Turn one impairment on; returns its heal (which counts once)."""
        entry = (kind, amount)
        with self._lock:
            self._on.append(entry)
        healed = False

        def heal() -> None:
            nonlocal healed
            with self._lock:
                if not healed:
                    healed = True
                    self._on.remove(entry)
        return heal

    def strongest(self, kind: Impairment) -> float | None:
        with self._lock:
            amounts = [a for k, a in self._on if k is kind]
        return max(amounts) if amounts else None

    @property
    def partitioned(self) -> bool:
        return self.strongest(Impairment.PARTITION) is not None

    @property
    def clear(self) -> bool:
        with self._lock:
            return not self._on

    def fate(self, reorder_hold: float = REORDER_HOLD) -> float | None:
        """For one datagram: None to drop it, else the seconds to hold it."""
        if self.partitioned:
            return None
        loss = self.strongest(Impairment.LOSS) or 0.0
        reorder = self.strongest(Impairment.REORDER) or 0.0
        with self._lock:
            lost = self._rng.random() < loss
            held = self._rng.random() < reorder
        if lost:
            return None
        return (self.strongest(Impairment.DELAY) or 0.0) + (reorder_hold if held else 0.0)

    def tcp_fate(self, reset_share: float = RESET_SHARE) -> TcpFate:
        """For one chunk of TCP bytes under the `loss` on now: passes, stalled or reset."""
        loss = self.strongest(Impairment.LOSS) or 0.0
        if loss <= 0:
            return TcpFate.PASS
        with self._lock:
            hit, reset = self._rng.random() < loss, self._rng.random() < reset_share
        return TcpFate.PASS if not hit else TcpFate.RESET if reset else TcpFate.STALL


class TcpFate(StrEnum):
    """What a lossy link does to a chunk of TCP bytes, as its ends see it."""

    PASS = "pass"
    STALL = "stall"  # held for a retransmission timeout
    RESET = "reset"  # the connection dropped


class _Relay:
    """What both relays share: a daemon thread running `_run` until `close`, which then
    closes the relay's sockets (`_close_sockets`)."""

    name = "chaos-relay"

    def __init__(self) -> None:
        self._stop = threading.Event()
        self._thread = threading.Thread(target=self._run, name=self.name, daemon=True)

    def start(self) -> Self:
        self._thread.start()
        return self

    def close(self) -> None:
        self._stop.set()
        if self._thread.is_alive():
            self._thread.join(timeout=5)
        self._close_sockets()

    def _run(self) -> None:
        raise NotImplementedError

    def _close_sockets(self) -> None:
        raise NotImplementedError


class UdpRelay(_Relay):
    """A UDP relay: a client (the RCL's link) sends to `address`; datagrams go to the
    upstream (the simulator) and its answers back to the last client heard."""

    name = "chaos-udp-relay"

    def __init__(self, upstream: Upstream, impairments: Impairments,
                 host: str = "127.0.0.1") -> None:
        self.upstream, self.impairments = upstream, impairments
        self.front = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
        self.front.bind((host, 0))
        self.back = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
        self.back.bind((host, 0))
        self.address: Address = self.front.getsockname()
        self.counts: Counter[str] = Counter()  # passed, dropped, held, reordered
        self.hold = REORDER_HOLD  # s a datagram picked for reordering is held back
        self._client: Address | None = None
        self._queue: list[tuple[float, int, socket.socket, bytes, Address]] = []
        self._seq = 0
        super().__init__()

    def _close_sockets(self) -> None:
        self.front.close()
        self.back.close()

    def _run(self) -> None:
        with selectors.DefaultSelector() as sel:
            sel.register(self.front, selectors.EVENT_READ)
            sel.register(self.back, selectors.EVENT_READ)
            while not self._stop.is_set():
                wait = TICK if not self._queue else \
                    max(0.0, min(TICK, self._queue[0][0] - time.monotonic()))
                for key, _ in sel.select(wait):
                    self._receive(key.fileobj)  # type: ignore[arg-type]
                self._send_due()

    def _receive(self, sock: socket.socket) -> None:
        try:
            data, sender = sock.recvfrom(DATAGRAM)
        except OSError:
            return
        if sock is self.front:
            self._client = sender
            target = self.upstream()
            out = self.back
        else:
            target, out = self._client, self.front
        if target is None:
            self.counts["no_peer"] += 1
            return
        hold = self.impairments.fate(self.hold)
        if hold is None:
            self.counts["dropped"] += 1
            return
        if hold <= 0 and not any(o is out for _, _, o, *_ in self._queue):
            self._send(out, data, target)
            return
        self.counts["held"] += 1
        self._seq += 1
        heapq.heappush(self._queue, (time.monotonic() + hold, self._seq, out, data, target))

    def _send_due(self) -> None:
        now = time.monotonic()
        while self._queue and self._queue[0][0] <= now:
            _, seq, out, data, target = heapq.heappop(self._queue)
            if any(s < seq and o is out for _, s, o, *_ in self._queue):
                self.counts["reordered"] += 1  # sent before one that came earlier
            self._send(out, data, target)

    def _send(self, out: socket.socket, data: bytes, target: Address) -> None:
        try:
            out.sendto(data, target)
            self.counts["passed"] += 1
        except OSError:
            self.counts["send_failed"] += 1


class TcpRelay(_Relay):
    """A TCP relay: each connection to `address` is joined to a new one to the upstream
    (marked `mark` (SO_MARK, needs root) when not 0: a packet filter's redirect that
    brought the traffic here lets the relay's own connection pass)."""

    name = "chaos-tcp-relay"

    def __init__(self, upstream: Upstream, impairments: Impairments,
                 host: str = "127.0.0.1", mark: int = 0) -> None:
        self.upstream, self.impairments = upstream, impairments
        self.mark = mark
        self.listener = socket.socket(socket.AF_INET, socket.SOCK_STREAM)
        self.listener.setsockopt(socket.SOL_SOCKET, socket.SO_REUSEADDR, 1)
        self.listener.bind((host, 0))
        self.listener.listen(16)
        self.listener.settimeout(TICK * 4)
        self.address: Address = self.listener.getsockname()
        self.counts: Counter[str] = Counter()  # connections, bytes, held, refused, stalled, reset
        self.stall = LOSS_STALL  # s a chunk hit by loss waits
        self.reset_share = RESET_SHARE  # ... or its connection is reset, this share of them
        self._lock = threading.Lock()
        self._sockets: set[socket.socket] = set()
        super().__init__()

    def _close_sockets(self) -> None:
        self.listener.close()
        with self._lock:
            for s in list(self._sockets):
                _close(s)

    def _run(self) -> None:  # accept connections until closed
        while not self._stop.is_set():
            try:
                client, _ = self.listener.accept()
            except TimeoutError:
                continue
            except OSError:
                return
            target = self.upstream()
            try:
                if target is None:
                    raise OSError("no upstream address")
                server = _connect(target, self.mark)
            except OSError:
                self.counts["refused"] += 1
                _close(client)
                continue
            self.counts["connections"] += 1
            for s in (client, server):
                s.settimeout(TICK * 4)
                with self._lock:
                    self._sockets.add(s)
            for src, dst in ((client, server), (server, client)):
                threading.Thread(target=self._pump, args=(src, dst), daemon=True,
                                 name="chaos-tcp-pump").start()

    def _pump(self, src: socket.socket, dst: socket.socket) -> None:
        reset = False
        try:
            while not self._stop.is_set():
                try:
                    data = src.recv(CHUNK)
                except TimeoutError:
                    continue
                if not data:
                    break
                self._hold(time.monotonic())
                fate = self.impairments.tcp_fate(self.reset_share)
                if fate is TcpFate.RESET:
                    self.counts["reset"] += 1
                    reset = True
                    break
                if fate is TcpFate.STALL:
                    self.counts["stalled"] += 1
                    self._stop.wait(self.stall)
                dst.sendall(data)
                self.counts["bytes"] += len(data)
        except OSError:
            pass
        finally:
            for s in (src, dst):
                if reset:
                    _abort(s)  # RST at once, no FIN first
                else:
                    _close(s)
                with self._lock:
                    self._sockets.discard(s)

    def _hold(self, received: float) -> None:
        """Wait while partitioned and until `delay` s after `received` (counted `held`)."""
        if self.impairments.strongest(Impairment.DELAY):
            self.counts["held"] += 1
        while not self._stop.is_set():
            delay = self.impairments.strongest(Impairment.DELAY) or 0.0
            left = received + delay - time.monotonic()
            if not self.impairments.partitioned and left <= 0:
                return
            time.sleep(min(TICK, max(left, 0.005)))


def _connect(target: Address, mark: int) -> socket.socket:
    if not mark:
        return socket.create_connection(target, timeout=5)
    s = socket.socket(socket.AF_INET, socket.SOCK_STREAM)
    try:
        s.setsockopt(socket.SOL_SOCKET, socket.SO_MARK, mark)
        s.settimeout(5)
        s.connect(target)
    except OSError:
        s.close()
        raise
    return s


def _abort(s: socket.socket) -> None:
    """Close with RST, not FIN: a connection reset, as a lossy link's end sees it."""
    try:
        s.setsockopt(socket.SOL_SOCKET, socket.SO_LINGER, struct.pack("ii", 1, 0))
    except OSError:
        pass
    s.close()


def _close(s: socket.socket) -> None:
    try:
        s.shutdown(socket.SHUT_RDWR)
    except OSError:
        pass
    s.close()
