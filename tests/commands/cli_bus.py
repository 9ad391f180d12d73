"""Helpers for the tests of `mrss send/record/replay`: a bus in a short run dir, CLI runs."""

from __future__ import annotations

import shutil
import subprocess
import sys
import tempfile
import threading
from collections.abc import Iterator
from contextlib import contextmanager
from dataclasses import dataclass, field
from pathlib import Path

from mrss.bus import BusEndpoints, ProxyThread, Stale, Subscriber
from mrss.messages import Envelope
from mrss.testing import wait_until

ROOT = Path(__file__).resolve().parents[2]


@contextmanager
def short_dir(prefix: str = "mrss-cli-") -> Iterator[Path]:
    """A short temporary directory (unix socket paths are limited to 107 bytes)."""
    path = Path(tempfile.mkdtemp(prefix=prefix))
    try:
        yield path
    finally:
        shutil.rmtree(path, ignore_errors=True)


@dataclass
class Bus:
    """A proxy on ipc sockets in `run_dir`, with a subscriber to everything on it."""

    run_dir: Path
    endpoints: BusEndpoints
    sub: Subscriber

    def next(self, timeout: float = 10.0) -> Envelope:
        env = self.sub.recv(timeout=timeout)
        assert env is not None, f"no message arrived within {timeout} s"
        return env


@contextmanager
def running_bus(prefixes: tuple[str, ...] = ("",)) -> Iterator[Bus]:
    """A proxy thread on a fresh run dir and a connected subscriber; both stopped after.

    The subscriber is an observer (`Stale.KEEP`): it sees replayed messages too, as the
    dashboard does (a component refuses them)."""
    with short_dir() as run_dir:
        endpoints = BusEndpoints.ipc(run_dir)
        with ProxyThread(endpoints):
            sub = Subscriber(endpoints, prefixes=prefixes, stale=Stale.KEEP)
            try:
                assert sub.wait_connected(10), "subscriber did not join the proxy"
                yield Bus(run_dir, endpoints, sub)
            finally:
                sub.close()


def mrss(*args: str, timeout: float = 60) -> subprocess.CompletedProcess[str]:
    """Run `python -m mrss ARGS` to completion."""
    return subprocess.run([sys.executable, "-m", "mrss", *args], cwd=ROOT,
                          capture_output=True, text=True, timeout=timeout)


@dataclass
class CliProcess:
    """A running `python -m mrss ...` whose stdout lines are collected by a thread."""

    proc: subprocess.Popen[str]
    lines: list[str] = field(default_factory=list)

    def __post_init__(self) -> None:
        self._reader = threading.Thread(target=self._read, daemon=True)
        self._reader.start()

    def _read(self) -> None:
        assert self.proc.stdout is not None
        for line in self.proc.stdout:
            self.lines.append(line.rstrip("\n"))

    def wait_line(self, start: str, timeout: float = 15.0) -> str:
        """The first stdout line starting with `start` (fails if the process ends first)."""
        def found() -> str | None:
            return next((line for line in self.lines if line.startswith(start)), None)

        wait_until(lambda: found() or self.proc.poll() is not None, timeout,
                   message=f"a line starting {start!r}")
        line = found()
        assert line is not None, f"process ended: {self.stderr()}"
        return line

    def finish(self, timeout: float = 30.0) -> int:
        code = self.proc.wait(timeout=timeout)
        self._reader.join(timeout=5)
        return code

    def stderr(self) -> str:
        if self.proc.poll() is None or self.proc.stderr is None:
            return ""
        return self.proc.stderr.read()

    def stop(self) -> None:
        """SIGTERM (a supervisor stops its components), then SIGKILL after 15 s."""
        if self.proc.poll() is None:
            self.proc.terminate()
            try:
                self.proc.wait(timeout=15)
            except subprocess.TimeoutExpired:
                self.proc.kill()
        self.proc.wait(timeout=10)


@contextmanager
def mrss_process(*args: str, env: dict[str, str] | None = None) -> Iterator[CliProcess]:
    """Start `python -m mrss ARGS`; it is stopped at the end if still running."""
    proc = subprocess.Popen([sys.executable, "-m", "mrss", *args], cwd=ROOT, env=env,
                            stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    cli = CliProcess(proc)
    try:
        yield cli
    finally:
        cli.stop()
        for stream in (proc.stdout, proc.stderr):
            if stream is not None:
                stream.close()
