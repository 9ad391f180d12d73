"""A whole MRSS system for the end-to-end tests: `mrss supervise e2e` as an OS process.

The root supervisor runs the bus proxy, the RCL and the reasoner as component
processes (tests/projects/e2e). The test only talks to them the way other components
do: it publishes percepts and commands on the bus and watches every status, request,
heartbeat, supervision event and mind snapshot there. Its log (every component's
stderr) is kept in `<run_dir>/supervise.log`.
"""

from __future__ import annotations

import os
import shutil
import subprocess
import sys
import tempfile
import threading
from collections.abc import Callable, Iterator
from contextlib import contextmanager
from pathlib import Path
from typing import Any, TypeVar

import psutil

from mrss.bus import BusEndpoints, Publisher, Subscriber
from mrss.messages import (
    ActionRequest,
    ActionStatus,
    Command,
    Envelope,
    Heartbeat,
    Message,
    MindSnapshot,
    Percept,
    SupEvent,
)
from mrss.testing import stop_supervised, wait_until

PROJECTS = Path(__file__).resolve().parent.parent / "projects"
WATCHED = ["action.", "rel.action", "mind.", "sup.", "robot.", "edge.rejections"]
M = TypeVar("M", bound=Message)


class System:
    """One supervised MRSS run plus a bus observer; `close()` always cleans up."""

    def __init__(self, run_dir: Path, project: str = "e2e", projects: Path = PROJECTS) -> None:
        self.run_dir = run_dir
        self.log_path = run_dir / "supervise.log"
        self.endpoints = BusEndpoints.ipc(run_dir)
        self._lock = threading.Lock()
        self.seen: list[Envelope] = []
        self.sub = Subscriber(self.endpoints, prefixes=WATCHED)
        self.sub.start(self._record)
        self.pub = Publisher(self.endpoints, src="tester")
        self._log = self.log_path.open("w")
        self.proc = subprocess.Popen(
            [sys.executable, "-m", "mrss", "supervise", project, "--run-dir", str(run_dir)],
            env={**os.environ, "MRSS_PROJECTS": str(projects)}, stdout=self._log,
            stderr=subprocess.STDOUT, start_new_session=True)

    # ------------------------------------------------------------ observing
    def _record(self, env: Envelope) -> None:
        with self._lock:
            self.seen.append(env)

    def envelopes(self, kind: type[M]) -> list[Envelope]:
        with self._lock:
            return [e for e in self.seen if isinstance(e.body, kind)]

    def bodies(self, kind: type[M]) -> list[M]:
        return [e.body for e in self.envelopes(kind)]  # type: ignore[misc]

    def requests(self, name: str | None = None) -> list[ActionRequest]:
        """Action requests seen on the reliable channel (a resend is listed once)."""
        out: dict[str, ActionRequest] = {}
        for req in self.bodies(ActionRequest):
            if name is None or req.name == name:
                out.setdefault(req.uuid, req)
        return list(out.values())

    def request(self, name: str, goal: str, timeout: float = 10.0) -> ActionRequest:
        """Wait for the agent's request `name(_, goal, ...)`."""
        def find() -> list[ActionRequest]:
            return [r for r in self.requests(name) if r.goal == goal]
        return wait_until(find, timeout, message=f"request {name} for goal {goal}")[-1]

    def statuses(self, uuid: str, repeats: bool = False) -> list[tuple[int, ActionStatus]]:
        """(RCL incarnation, status) for one action, in arrival order: its transitions,
        and with `repeats` also the statuses sent again by reconciliation."""
        return [(e.inc, e.body) for e in self.envelopes(ActionStatus)
                if isinstance(e.body, ActionStatus) and e.body.uuid == uuid
                and (repeats or not e.body.repeat)]

    def last_state(self, uuid: str) -> str | None:
        found = self.statuses(uuid)
        return found[-1][1].state if found else None

    def wait_state(self, uuid: str, *states: str, timeout: float = 10.0) -> ActionStatus:
        """Wait for a status of `uuid` in one of `states`; returns the first such."""
        def find() -> list[ActionStatus]:
            return [s for _, s in self.statuses(uuid) if s.state in states]
        return wait_until(find, timeout, message=f"action {uuid} {'/'.join(states)}")[0]

    def pid(self, component: str, inc: int | None = None) -> int | None:
        """The pid of a component (its bus heartbeats), optionally of one incarnation."""
        beats = [e for e in self.envelopes(Heartbeat)
                 if e.body.component == component  # type: ignore[attr-defined]
                 and (inc is None or e.inc == inc)]
        return beats[-1].body.pid if beats else None  # type: ignore[attr-defined]

    def incarnation(self, component: str) -> int:
        beats = [e.inc for e in self.envelopes(Heartbeat)
                 if e.body.component == component]  # type: ignore[attr-defined]
        return max(beats, default=0)

    def sup_events(self, child: str) -> list[SupEvent]:
        return [b for b in self.bodies(SupEvent) if b.child == child]

    def log_text(self) -> str:
        self._log.flush()
        return self.log_path.read_text(errors="replace")

    # ------------------------------------------------------------ acting
    def percept(self, literal: str, op: str = "add") -> None:
        self.pub.publish(Percept(literal=literal, op=op))

    def publish(self, message: Message, topic: str | None = None) -> None:
        self.pub.publish(message, topic=topic)

    def mind(self, timeout: float = 2.0) -> MindSnapshot | None:
        """Ask the reasoner for a mind snapshot; the first one that comes back (or None)."""
        before = len(self.envelopes(MindSnapshot))
        self.pub.publish(Command(command="mind", target="reasoner"))
        try:
            return wait_until(lambda: self.bodies(MindSnapshot)[before:], timeout,
                              interval=0.01, message="mind snapshot")[-1]
        except AssertionError:
            return None

    def wait_mind(self, condition: Callable[[MindSnapshot], Any], timeout: float = 10.0,
                  message: str = "mind") -> MindSnapshot:
        """Poll mind snapshots until one satisfies `condition`; return it."""
        def check() -> list[MindSnapshot]:
            snap = self.mind(timeout=1.0)
            return [snap] if snap is not None and condition(snap) else []
        return wait_until(check, timeout, interval=0.05, message=message)[0]

    def wait_ready(self, timeout: float = 30.0) -> None:
        """Every component up: the reasoner answers on the bus, both heartbeat there.

        (A mind reply can come before the reasoner's first heartbeat arrives, and tests
        find a component's pid by its heartbeats.)
        """
        def ready() -> bool:
            if self.proc.poll() is not None:
                raise AssertionError(f"mrss supervise exited:\n{self.log_text()}")
            return self.pid("rcl") is not None and self.mind(timeout=0.5) is not None \
                and self.pid("reasoner") is not None
        wait_until(ready, timeout, interval=0.05, message="the system answering on the bus")

    def tree_pid(self, child: str, timeout: float = 10.0) -> int:
        """The pid of `child` as the root supervisor reports it (`ctl.tree`): for
        components that send no heartbeat of their own, like the bus proxy."""
        def ask() -> int:
            before = len(self.bodies(SupEvent))
            self.pub.publish(Command(command="tree"))
            try:
                trees = wait_until(lambda: [e for e in self.bodies(SupEvent)[before:]
                                            if e.event == "tree"], 1.0, interval=0.01)
            except AssertionError:
                return 0
            return _find_pid(trees[-1].detail.get("tree"), child)
        return wait_until(ask, timeout, interval=0.05, message=f"the pid of {child}")

    def signal(self, component: str, sig: int) -> int:
        """Send `sig` to a component's current process; returns its pid."""
        pid = self.pid(component)
        assert pid is not None, f"no heartbeat from {component} yet"
        os.kill(pid, sig)
        return pid

    def close(self) -> None:
        """SIGTERM the root supervisor (orderly stop), then kill whatever is left."""
        try:
            stop_supervised(self.proc)
        finally:
            self.sub.close()
            self.pub.close()
            self._log.close()


def beliefs(snap: MindSnapshot, prefix: str) -> list[str]:
    """The beliefs of a snapshot starting with `prefix` (e.g. "patrolled(")."""
    return [b for b in snap.beliefs if b.startswith(prefix)]


def waiting_on_actions(snap: MindSnapshot) -> list[Any]:
    """Intentions of a snapshot blocked on an environment action."""
    return [i for i in snap.intentions
            if isinstance(i, dict) and str(i.get("waiting_on") or "").startswith("action")]


def _find_pid(tree: Any, child: str) -> int:
    """The pid of the node `child` in a `sup.tree` snapshot (0: not there or not running)."""
    if not isinstance(tree, dict):
        return 0
    if tree.get("id") == child and tree.get("state") == "running":
        return int(tree.get("pid") or 0)
    for node in tree.get("children") or []:
        found = _find_pid(node, child)
        if found:
            return found
    return 0


def _descendants() -> set[int]:
    return {p.pid for p in psutil.Process().children(recursive=True)}


@contextmanager
def running_system(projects: Path = PROJECTS) -> Iterator[System]:
    """`mrss supervise e2e` (from `projects`) in a fresh run dir (short ipc paths), ready
    for percepts; torn down, and checked for processes left behind, even on failure."""
    before = _descendants()
    run_dir = Path(tempfile.mkdtemp(prefix="mrss-e2e-"))
    sys_ = System(run_dir, projects=projects)
    try:
        sys_.wait_ready()
        yield sys_
    finally:
        tree = psutil.Process(sys_.proc.pid).children(recursive=True) \
            if sys_.proc.poll() is None else []
        sys_.close()
        left = [p for p in tree if p.is_running() and p.status() != psutil.STATUS_ZOMBIE]
        for p in left:
            p.kill()
        if not os.environ.get("MRSS_E2E_KEEP"):
            shutil.rmtree(run_dir, ignore_errors=True)
        assert not left, f"processes left behind: {[p.pid for p in left]}"
        assert _descendants() <= before | {sys_.proc.pid}
