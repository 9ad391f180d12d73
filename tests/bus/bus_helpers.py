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


def reach_every_subscriber(sock: zmq.Socket[bytes], endpoints: BusEndpoints) -> None:
    """Connect a raw ZeroMQ PUB socket where it reaches every subscriber of the bus, as
    any process on the host could: the proxy's frontend (a bus that forwards) and, on a
    direct bus over ipc, each member's socket beside it (docs/bus.md, "Direct
    delivery"). Members that bind after this are not reached."""
    sock.connect(endpoints.frontend)
    if endpoints.backend.startswith("ipc://"):
        folder = Path(endpoints.backend[len("ipc://"):]).parent
        for member in sorted(folder.glob("bus-m-*.sock")):
            sock.connect(f"ipc://{member}")
