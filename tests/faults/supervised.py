"""`mrss supervise PROJECT` as a real process, watched and faulted the way an operator would.

The root's tree comes from its `ctl.tree` answers on the bus (as the dashboard gets it),
its `sup.*` events from a subscriber, faults are real signals to the component
processes. Its log (the root's and every component's stderr) is `<run_dir>/../NAME.log`.
`close()` always stops the system and kills whatever is left.
"""

from __future__ import annotations

import os
import signal
import subprocess
import sys
import threading
import time
from collections.abc import Mapping, Sequence
from pathlib import Path
from typing import Any

import psutil

from mrss.bus import BusEndpoints, Publisher, Subscriber
from mrss.messages import Command, Envelope, LogRecord, SupEvent
from mrss.runtime.forkserver import is_fork_server
from mrss.testing import WaitTimeout, process_gone, wait_until

REPO = Path(__file__).resolve().parent.parent.parent
SHIPPED = REPO / "projects"  # wildfire and template, as shipped
TEST_PROJECTS = REPO / "tests" / "projects"


class Supervised:
    """One `mrss supervise` run of a project, its tree and events seen over the bus."""

    def __init__(self, project: str, run_dir: Path, *, projects: Path = SHIPPED,
                 env: Mapping[str, str] | None = None,
                 prefixes: Sequence[str] = ("sup.",)) -> None:
        self.run_dir = run_dir
        run_dir.mkdir(parents=True, exist_ok=True)
        self.log_path = run_dir.parent / f"{project}-supervise.log"
        self._lock = threading.Lock()
        self.events: list[SupEvent] = []
        self.logs: list[LogRecord] = []
        self._trees: list[dict[str, Any]] = []
        self.killed: set[int] = set()  # pids this test killed: never "running" again
        endpoints = BusEndpoints.ipc(run_dir)
        self.sub = Subscriber(endpoints, prefixes=list(prefixes), name="faults-test")
        self.sub.start(self._record)
        self.pub = Publisher(endpoints, src="faults-test", batching=False)
        self._log = self.log_path.open("w")
        self.proc = subprocess.Popen(
            [sys.executable, "-m", "mrss", "supervise", project, "--run-dir", str(run_dir),
             "--no-tui"], env={**os.environ, "MRSS_PROJECTS": str(projects), **(env or {})},
            stdout=self._log, stderr=subprocess.STDOUT, start_new_session=True)

    # -- watching ----------------------------------------------------------------------
    def _record(self, env: Envelope) -> None:
        body = env.body
        if isinstance(body, LogRecord):
            with self._lock:
                self.logs.append(body)
        if not isinstance(body, SupEvent):
            return
        with self._lock:
            if body.event == "tree" and isinstance(body.detail.get("tree"), dict):
                self._trees.append(body.detail["tree"])  # type: ignore[arg-type]
            else:
                self.events.append(body)

    def of(self, event: str, child: str | None = None) -> list[SupEvent]:
        with self._lock:
            return [e for e in self.events
                    if e.event == event and (child is None or e.child == child)]

    def of_child(self, child: str) -> list[SupEvent]:
        """Every supervision event about `child`, in the order heard."""
        with self._lock:
            return [e for e in self.events if e.child == child]

    def tree(self, timeout: float = 20.0) -> dict[str, Any]:
        """The root's tree, asked for over the bus now (a fresh answer). Asked while a
        chaos test kills components, the bus proxy among them, on a loaded machine: the
        answer may wait for the proxy's restart, hence the long `timeout`."""
        with self._lock:
            seen = len(self._trees)

        asked = [-1.0]  # when the question last went out

        def answer() -> dict[str, Any] | None:
            self.alive()
            with self._lock:
                if len(self._trees) > seen:
                    return self._trees[-1]
            if time.monotonic() - asked[0] >= 0.1:  # asked again every 0.1 s, while the
                self.pub.publish(Command(command="tree"))  # answer is taken at once
                asked[0] = time.monotonic()
            return None

        found: dict[str, Any] = wait_until(answer, timeout, interval=0.005,
                                           message="a ctl.tree answer")
        return found

    def children(self) -> dict[str, dict[str, Any]]:
        """The root's children by id, from a fresh tree."""
        return {c["id"]: c for c in self.tree()["children"]}

    def running(self) -> dict[str, dict[str, Any]]:
        """The children running now, by id, from a fresh tree. A child whose killed
        process the root has not reaped yet still reads "running" with the dead pid:
        it is left out until its new incarnation runs."""
        return self._running(self.children())

    def _running(self, kids: dict[str, dict[str, Any]]) -> dict[str, dict[str, Any]]:
        return {cid: c for cid, c in kids.items()
                if c["state"] == "running" and c.get("pid") not in self.killed}

    def wait_all_running(self, timeout: float = 60.0) -> dict[str, dict[str, Any]]:
        """Wait until every component of the project runs; its children by id."""
        def all_up() -> dict[str, dict[str, Any]] | None:
            self.alive()
            try:
                kids = self.children()
            except WaitTimeout:
                return None  # no answer this time (e.g. the proxy restarting): ask again
            up = self._running(kids)
            return up if kids and up.keys() == kids.keys() else None
        found: dict[str, dict[str, Any]] = wait_until(
            all_up, timeout, interval=0.2, message="every component running")
        return found

    def alive(self) -> None:
        if self.proc.poll() is not None:
            raise AssertionError(f"mrss supervise exited with {self.proc.returncode}:\n"
                                 f"{self.log_text()[-4000:]}")

    def log_text(self) -> str:
        self._log.flush()
        return self.log_path.read_text(errors="replace")

    # -- faults ------------------------------------------------------------------------
    def kill(self, pid: int) -> None:
        """SIGKILL one process of the tree and wait until it is gone."""
        self.killed.add(pid)
        os.kill(pid, signal.SIGKILL)
        wait_until(lambda: not _alive(pid), 10, message=f"pid {pid} gone")

    def fork_server(self) -> psutil.Process | None:
        """The root's fork server process (None unless there is exactly one)."""
        servers = []
        for p in psutil.Process(self.proc.pid).children():
            try:
                if is_fork_server(p.cmdline(), p.name()) and _alive(p.pid):
                    servers.append(p)
            except psutil.NoSuchProcess:
                pass
        return servers[0] if len(servers) == 1 else None

    def close(self) -> int | None:
        """SIGTERM the root (an orderly stop); kill what is left. Its exit code."""
        try:
            if self.proc.poll() is None:
                tree = psutil.Process(self.proc.pid).children(recursive=True)
                self.proc.send_signal(signal.SIGTERM)
                try:
                    self.proc.wait(timeout=60)
                except subprocess.TimeoutExpired:
                    os.killpg(self.proc.pid, signal.SIGKILL)
                    self.proc.wait(timeout=10)
                for p in tree:
                    if _alive(p.pid):
                        p.kill()
            return self.proc.returncode
        finally:
            self.sub.close()
            self.pub.close()
            self._log.close()


def _alive(pid: int) -> bool:
    return not process_gone(pid)
