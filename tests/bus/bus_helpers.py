"""Helpers for bus tests: child processes with collected stdout, joining pub and sub."""

from __future__ import annotations

import itertools
import signal
import subprocess
import threading
import time
from collections.abc import Callable
from pathlib import Path

import zmq

from mrss.bus import BusEndpoints, Publisher, Subscriber
from mrss.bus.direct import alive
from mrss.messages import Envelope, Message
from mrss.testing import wait_until

ROOT = Path(__file__).resolve().parents[2]


class BusProcess:
    """A child process whose stdout lines are collected by a reader thread."""

    def __init__(self, argv: list[str]) -> None:
        self.argv = argv
        self.lines: list[str] = []
        self.proc = subprocess.Popen(
            argv, cwd=ROOT, stdin=subprocess.PIPE, stdout=subprocess.PIPE,
            stderr=subprocess.PIPE, text=True)
        self._reader = threading.Thread(target=self._read, daemon=True)
        self._reader.start()

    def _read(self) -> None:
        assert self.proc.stdout is not None
        for line in self.proc.stdout:
            self.lines.append(line.rstrip("\n"))

    def tell(self, line: str) -> None:
        """Write `line` to the process's stdin (a peer that reads it, e.g. a gated sender)."""
        assert self.proc.stdin is not None
        self.proc.stdin.write(line + "\n")
        self.proc.stdin.flush()

    @property
    def pid(self) -> int:
        return self.proc.pid

    def alive(self) -> bool:
        return self.proc.poll() is None

    def wait_ready(self, timeout: float = 15.0) -> BusProcess:
        wait_until(lambda: self._ready_line() or not self.alive(), timeout,
                   message=f"{self.argv[2:5]} ready")
        if not self._ready_line():
            raise AssertionError(f"{self.argv} failed: {self.stderr()}")
        return self

    def _ready_line(self) -> bool:
        return bool(self.lines) and self.lines[0].startswith("ready")

    def kill(self) -> None:
        """SIGKILL, the way a crash ends a process."""
        if self.alive():
            self.proc.send_signal(signal.SIGKILL)
        self.proc.wait(timeout=10)

    def stop(self) -> None:
        """SIGTERM, then SIGKILL if it does not go within 5 s."""
        if self.alive():
            self.proc.terminate()
            try:
                self.proc.wait(timeout=5)
            except subprocess.TimeoutExpired:
                self.proc.kill()
                self.proc.wait(timeout=5)
        self._reader.join(timeout=5)

    def stderr(self) -> str:
        if self.alive() or self.proc.stderr is None:
            return ""
        return self.proc.stderr.read()


Spawn = Callable[..., BusProcess]


def sync(pub: Publisher, sub: Subscriber, make: Callable[[int], Message],
         timeout: float = 10.0) -> None:
    """Publish `make(k)` for k = 1, 2, ... until `sub` receives one.

    PUB/SUB joins take a moment; after this the path pub -> proxy -> sub is up. Messages
    of one publisher arrive in order, so no older sync message can arrive after this.
    """
    counter = itertools.count(1)

    def arrived() -> bool:
        want = make(next(counter))
        pub.publish(want)
        deadline = time.monotonic() + 0.05
        while (env := sub.recv(timeout=max(0.0, deadline - time.monotonic()))) is not None:
            if env.body == want:
                return True
        return False

    wait_until(arrived, timeout, interval=0, message="publisher and subscriber joined")


def receive_until(sub: Subscriber, done: Callable[[list[Envelope]], bool],
                  timeout: float = 10.0, what: str = "the end of the stream") -> list[Envelope]:
    """What `sub` receives until `done(received so far)` holds; fails after `timeout`.

    Never a quiet spell taken for "everything arrived": a stalled machine makes this
    wait, not truncate the list.
    """
    got: list[Envelope] = []
    deadline = time.monotonic() + timeout
    while not done(got):
        left = deadline - time.monotonic()
        env = sub.recv(timeout=max(0.0, min(left, 0.1)))
        if env is not None:
            got.append(env)
        elif left <= 0:
            raise AssertionError(f"{what} not seen within {timeout} s; received "
                                 f"{[e.body for e in got][-5:]} (last 5 of {len(got)})")
    return got


def drain_until(sub: Subscriber, *ends: Message, timeout: float = 10.0) -> list[Envelope]:
    """Everything `sub` receives up to and including each of `ends`, end markers its
    publishers published last.

    One publisher's messages arrive in the order it published them, so once its end
    marker is in, so is everything it published before: the list is complete, and a
    message lost before the marker shows as missing.
    """
    missing = list(ends)

    def all_ends_in(got: list[Envelope]) -> bool:
        if got and got[-1].body in missing:
            missing.remove(got[-1].body)
        return not missing

    return receive_until(sub, all_ends_in, timeout, what=f"the end markers {ends}")



class RawPublisher:
    """Raw ZeroMQ sockets that reach every subscriber of the bus, as any process on the
    host could: one on the proxy's frontend (a bus that forwards) and, on a direct bus
    over ipc, one on each member's socket beside it (docs/bus.md, "Direct delivery").
    Each is an XPUB, so `wait_joined` can tell when every member's subscriptions are in
    (a PUB drops what it sends before): from then on, what `send_multipart` sends
    reaches each of them, in order. Members that bind after it is made are not reached."""

    def __init__(self, endpoints: BusEndpoints, linger_ms: int = 0) -> None:
        targets = [endpoints.frontend]
        if endpoints.backend.startswith("ipc://"):
            folder = Path(endpoints.backend[len("ipc://"):]).parent
            targets += [f"ipc://{member}" for member in sorted(folder.glob("bus-m-*.sock"))
                        if alive(int(member.name.split("-")[2]))]  # not a killed one's file
        self.socks: list[zmq.Socket[bytes]] = []
        for target in targets:
            sock: zmq.Socket[bytes] = zmq.Context.instance().socket(zmq.XPUB)
            sock.setsockopt(zmq.LINGER, linger_ms)
            sock.connect(target)
            self.socks.append(sock)
        self._heard = [False] * len(self.socks)

    def joined(self) -> bool:
        """Whether every socket has had a subscription (its peer's are in)."""
        for i, sock in enumerate(self.socks):
            while sock.poll(0):
                sock.recv()
                self._heard[i] = True
        return all(self._heard)

    def wait_joined(self, timeout: float = 10.0) -> RawPublisher:
        wait_until(self.joined, timeout, message="every member's subscriptions in")
        return self

    def send_multipart(self, frames: list[bytes] | tuple[bytes, ...]) -> None:
        for sock in self.socks:
            sock.send_multipart(frames)

    def close(self) -> None:
        for sock in self.socks:
            sock.close()
