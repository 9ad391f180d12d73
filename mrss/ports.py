"""Free ports to name in advance (loopback endpoints, the embedded broker, tests).

A port chosen now and bound later by another socket or process can be taken in
between. The kernel hands out ports of its ephemeral range on its own (`bind(port 0)`,
`tcp://host:*`, the source port of every outgoing connection), so a port chosen there
and freed again can go to any of those. The rule here: choose outside the ephemeral
range (`/proc/sys/net/ipv4/ip_local_port_range`), where the kernel never assigns by
itself, at random, never the same port twice in one process, and only a port that
binds now. Where no such range can be read or nothing is left outside it, the kernel
chooses (port 0), as before.

Processes that run side by side and choose at the same time (the test suite's parallel
workers, each with its own systems) can each be given a share of their own:
`MRSS_PORTS=LOW-HIGH` in the environment narrows the choice to those ports (still outside
the ephemeral range). A process's children inherit it.
"""

from __future__ import annotations

import functools
import os
import random
import socket
import threading
from collections.abc import Iterable, Sequence
from pathlib import Path
from typing import overload

_RANGE_FILE = Path("/proc/sys/net/ipv4/ip_local_port_range")
SHARE_VARIABLE = "MRSS_PORTS"  # LOW-HIGH: this process's (and its children's) share
_LOWEST = 10_000  # below: well-known and registered services of the host
_DRAWS = 200  # random tries before the kernel chooses
_handed_out: set[tuple[int, int]] = set()  # (socket kind, port)
_lock = threading.Lock()


def free_ports(count: int, host: str = "127.0.0.1",
               kind: socket.SocketKind = socket.SOCK_STREAM) -> list[int]:
    """`count` distinct ports on `host` that nothing is bound to right now (TCP, or
    `kind=socket.SOCK_DGRAM` for UDP)."""
    with _lock:
        ports = _choose(count, host, kind)
        _handed_out.update((kind, port) for port in ports)
        return ports


def free_port(host: str = "127.0.0.1") -> int:
    """One TCP port on `host` that nothing listens on right now."""
    return free_ports(1, host)[0]


def free_udp_port(host: str = "127.0.0.1") -> int:
    """One UDP port on `host` that nothing is bound to right now."""
    return free_ports(1, host, socket.SOCK_DGRAM)[0]


def _choose(count: int, host: str, kind: socket.SocketKind) -> list[int]:
    found: list[int] = []
    allowed = _allowed()
    for _ in range(_DRAWS if allowed else 0):
        if len(found) == count:
            break
        port = random.choice(allowed)
        if (kind, port) not in _handed_out and port not in found \
                and _binds(host, port, kind):
            found.append(port)
    while len(found) < count:  # no range known, or nothing free found outside it
        port = _kernel_port(host, kind)
        if port not in found:
            found.append(port)
    return found


def shares(count: int) -> list[str]:
    """The ports outside the ephemeral range cut into `count` disjoint shares, each as a
    `MRSS_PORTS` value (empty where no range can be read)."""
    allowed = outside_ephemeral()
    if not allowed:
        return []
    size = len(allowed) // count
    return [f"{allowed[i * size]}-{allowed[(i + 1) * size - 1]}" for i in range(count)]


class Ports(Sequence[int]):
    """Ports as a few ranges, indexable as one sequence: the ~27,000 ports outside the
    ephemeral range as a list took ~1 MiB in every process that chose one."""

    def __init__(self, spans: Iterable[range]) -> None:
        self.spans = [span for span in spans if len(span)]
        self._len = sum(len(span) for span in self.spans)

    def __len__(self) -> int:
        return self._len

    @overload
    def __getitem__(self, index: int) -> int: ...

    @overload
    def __getitem__(self, index: slice) -> Sequence[int]: ...

    def __getitem__(self, index: int | slice) -> int | Sequence[int]:
        if isinstance(index, slice):
            return [self[i] for i in range(*index.indices(self._len))]
        if index < 0:
            index += self._len
        if not 0 <= index < self._len:
            raise IndexError(index)
        for span in self.spans:
            if index < len(span):
                return span[index]
            index -= len(span)
        raise IndexError(index)

    def __contains__(self, port: object) -> bool:
        return any(port in span for span in self.spans)

    def within(self, low: int, high: int) -> Ports:
        """The ports of these from `low` to `high`, both included."""
        return Ports(range(max(s.start, low), min(s.stop, high + 1)) for s in self.spans)


@functools.cache
def outside_ephemeral() -> Ports:
    """The ports outside the kernel's ephemeral range (none if it cannot be read)."""
    try:
        low, high = (int(n) for n in _RANGE_FILE.read_text().split())
    except (OSError, ValueError):
        return Ports(())
    return Ports((range(_LOWEST, min(low, 65536)), range(max(high + 1, _LOWEST), 65536)))


@functools.cache
def _allowed() -> Ports:
    """Outside the ephemeral range, and within this process's share if it has one."""
    share = os.environ.get(SHARE_VARIABLE, "")
    if not share:
        return outside_ephemeral()
    try:
        low, high = (int(n) for n in share.split("-"))
    except ValueError:
        raise ValueError(f"{SHARE_VARIABLE}={share!r}: expected LOW-HIGH, two port "
                         "numbers (e.g. 10000-20000)") from None
    return outside_ephemeral().within(low, high)


def _binds(host: str, port: int, kind: socket.SocketKind) -> bool:
    with socket.socket(socket.AF_INET, kind) as s:
        try:
            s.bind((host, port))
        except OSError:
            return False
        return True


def _kernel_port(host: str, kind: socket.SocketKind) -> int:
    with socket.socket(socket.AF_INET, kind) as s:
        s.bind((host, 0))
        port: int = s.getsockname()[1]
        return port
