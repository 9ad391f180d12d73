"""Helpers for a project's test procedures (projects/<name>/procedures/): the real system.

    with RunningProject(PROJECT_DIR, tmp_path / "run", env={"MRSS_SIM_SPEEDUP": "20"}) as s:
        s.wait_ready()                               # RCL and reasoner heartbeats seen
        s.publish("mrss/ui/goto", {"goal": "g1", ...})   # as an operator, over MQTT
        s.wait_for(lambda: s.statuses("robot1", "succeeded"), 20, "the action")
        s.world("robot1")                            # world model object, over HTTP
        assert s.interrupt() == 0                    # Ctrl-C: clean stop, nothing left

`mrss supervise NAME --run-dir DIR` runs as its own process (`sys.executable -m mrss`,
the project's parent folder as $MRSS_PROJECTS); what it does is watched from the
outside: the bus (percepts, action statuses, heartbeats), the world model's HTTP API
and the broker, all found in the run folder. Whatever happens, `close()` (the end of
the `with`) kills what is left of the process tree.
"""

from __future__ import annotations

import json
import os
import signal
import subprocess
import threading
import urllib.error
import urllib.request
from collections.abc import Callable, Mapping
from pathlib import Path
from types import TracebackType
from typing import Any, TypeVar
from urllib.parse import quote

import psutil

from mrss.bus import Publisher, Subscriber
from mrss.bus.settings import endpoints_from_config
from mrss.edge.http_token import project_token
from mrss.errors import MrssError
from mrss.interpreter import python_module
from mrss.links.connect import project_broker_url
from mrss.links.mqtt_publish import publish_json
from mrss.messages import ActionStatus, Envelope, Heartbeat, JsonValue, Percept, RobotData
from mrss.messages.credentials import KEY_FILE
from mrss.runtime.forkserver import COMPONENT_COMM_PREFIX
from mrss.testing import WaitTimeout, wait_until

T = TypeVar("T")


class RunningProject:
    """`mrss supervise` of one project folder as a process, and views of its system."""

    def __init__(self, project_dir: Path, run_dir: Path,
                 env: Mapping[str, str] | None = None, node: str = "",
                 prefix: tuple[str, ...] = ()) -> None:
        self.project_dir = project_dir.resolve()
        self.run_dir = run_dir
        self.node = node  # with [nodes]: the node this runs (`--node`)
        self.prefix = prefix  # run under it, e.g. ("ip", "netns", "exec", NAME)
        self.output = run_dir.parent / f"{self.project_dir.name}-supervise.log"
        self.env = dict(os.environ, MRSS_PROJECTS=str(self.project_dir.parent), **(env or {}))
        self.process: subprocess.Popen[bytes] | None = None
        self.percepts: list[str] = []
        self.percept_log: list[tuple[str, str, str, int]] = []  # op, literal, src, inc
        self.status_log: list[ActionStatus] = []
        self.latest: dict[str, ActionStatus] = {}  # uuid -> newest status, repeats too
        self.heartbeats: set[str] = set()
        self.incarnations: dict[str, tuple[int, int]] = {}  # component -> (inc, pid)
        self._lock = threading.Lock()
        self._sub: Subscriber | None = None
        self._pub: Publisher | None = None
        self._owner_pub: tuple[tuple[str, int], Publisher] | None = None
        self._tree: list[psutil.Process] = []
        self._token: tuple[str | None] | None = None  # the world model token, once read

    # -- life cycle ------------------------------------------------------------------------
    def start(self, timeout: float = 20.0) -> RunningProject:
        """Start the system and listen to its bus (returns once the proxy is up, which may
        take `timeout` seconds: its fork server imports every component's module first)."""
        self.run_dir.mkdir(parents=True, exist_ok=True)
        with self.output.open("wb") as sink:
            self.process = subprocess.Popen(
                [*self.prefix, *python_module(
                    "mrss", "supervise", self.project_dir.name, "--run-dir", str(self.run_dir),
                    *(("--node", self.node) if self.node else ()))],
                stdout=sink, stderr=subprocess.STDOUT, env=self.env)
        self.wait_for(lambda: (self.run_dir / "bus-pub.sock").exists(), timeout,
                      "the bus proxy")
        self._sub = Subscriber(endpoints_from_config({}, self.run_dir, nodes=bool(self.node)),
                               prefixes=["percept", "action.status", "sup.heartbeat."])
        self._sub.start(self._on_message)
        return self

    def __enter__(self) -> RunningProject:
        return self.start()

    def __exit__(self, kind: type[BaseException] | None, exc: BaseException | None,
                 tb: TracebackType | None) -> None:
        self.close()

    def wait_ready(self, components: tuple[str, ...] = ("rcl", "reasoner"),
                   timeout: float = 30.0) -> None:
        """Wait until every component named has sent a heartbeat on the bus."""
        self.wait_for(lambda: set(components) <= self.heartbeats, timeout,
                      f"heartbeats of {', '.join(components)}")
        self._tree = self._children()

    def interrupt(self, timeout: float = 30.0) -> int:
        """Ctrl-C: the exit code; AssertionError if a component process is left over."""
        assert self.process is not None
        tree = self._tree or self._children()
        self.process.send_signal(signal.SIGINT)
        code = self.process.wait(timeout)
        try:
            wait_until(lambda: not [p for p in tree if _alive(p)], 10,
                       message="the component processes to end")
        except WaitTimeout:
            raise AssertionError(f"left over: {[p.pid for p in tree if _alive(p)]}") from None
        return code

    def close(self) -> None:
        """Stop listening; kill the process tree if it still runs."""
        if self._sub is not None:
            self._sub.close()
            self._sub = None
        if self._pub is not None:
            self._pub.close()
            self._pub = None
        if self._owner_pub is not None:
            self._owner_pub[1].close()
            self._owner_pub = None
        if self.process is not None and self.process.poll() is None:
            tree = self._children()
            self.process.kill()
            for child in tree:
                try:
                    child.kill()
                except psutil.NoSuchProcess:
                    pass
            self.process.wait(10)

    def _children(self) -> list[psutil.Process]:
        assert self.process is not None
        try:
            children: list[psutil.Process] = psutil.Process(self.process.pid).children(
                recursive=True)
        except psutil.NoSuchProcess:
            return []
        return children

    # -- watching --------------------------------------------------------------------------
    def wait_for(self, condition: Callable[[], T], timeout: float, what: str) -> T:
        """wait_until, failing early (with the log) if the system exits meanwhile."""
        def check() -> T | None:
            value = condition()
            if not value and self.process is not None and self.process.poll() is not None:
                raise AssertionError(f"mrss supervise exited ({self.process.returncode}) "
                                     f"while waiting for {what}:\n{self.log()}")
            return value
        try:
            return wait_until(check, timeout, interval=0.02, message=what)  # type: ignore[return-value]
        except WaitTimeout as exc:
            raise AssertionError(f"{exc}\n--- log ---\n{self.log()}") from None

    def _on_message(self, env: Envelope) -> None:
        body = env.body
        with self._lock:
            if isinstance(body, Percept):
                self.percept_log.append((body.op, body.literal, env.src, env.inc))
                if body.op == "add":
                    self.percepts.append(body.literal)
            elif isinstance(body, ActionStatus):
                self.latest[body.uuid] = body  # progress goes out as repeat statuses
                if not body.repeat:  # the log: transitions only
                    self.status_log.append(body)
            elif isinstance(body, Heartbeat):
                self.heartbeats.add(body.component)
                if env.inc >= self.incarnations.get(body.component, (0, 0))[0]:
                    self.incarnations[body.component] = (env.inc, body.pid)

    def statuses(self, robot: str | None = None, state: str | None = None) -> list[ActionStatus]:
        """Action statuses seen, of a robot and/or in a state."""
        with self._lock:
            return [s for s in self.status_log if (robot is None or s.robot == robot)
                    and (state is None or s.state == state)]

    def progress(self, uuid: str) -> dict[str, JsonValue]:
        """An action's newest progress: its latest status, a transition or a repeat (the
        RCL sends progress as repeat statuses, which `statuses()` leaves out)."""
        with self._lock:
            status = self.latest.get(uuid)
            return dict(status.progress) if status is not None else {}

    def incarnation(self, component: str) -> int:
        """The newest incarnation of a component heard heartbeating (0: none yet)."""
        with self._lock:
            return self.incarnations.get(component, (0, 0))[0]

    def signal(self, component: str, sig: int = signal.SIGKILL) -> int:
        """Send `sig` to a component's current process (a fault, as the dashboard's `k`
        sends): the one heartbeating, else the one in the supervisor's tree; its pid."""
        with self._lock:
            inc, pid = self.incarnations.get(component, (0, 0))
        pid = pid or self.component_pid(component)
        assert pid, f"no heartbeat from {component} yet, nor a process of it"
        os.kill(pid, sig)
        return pid

    def component_pid(self, component: str) -> int:
        """The pid of the component's live process in the supervisor's tree (0: none):
        forked, it is named `mrss:<component>`; started, its argv says `--name`."""
        comm = f"{COMPONENT_COMM_PREFIX}{component}"[:15]
        for child in self._children():
            try:
                argv = child.cmdline()
                if child.status() != psutil.STATUS_ZOMBIE and (
                        child.name() == comm or ("--name" in argv and argv[
                            argv.index("--name") + 1:][:1] == [component])):
                    return int(child.pid)
            except (psutil.NoSuchProcess, psutil.AccessDenied):
                continue
        return 0

    def perceived(self, prefix: str) -> list[str]:
        """Percepts (added) whose literal starts with `prefix`."""
        with self._lock:
            return [p for p in self.percepts if p.startswith(prefix)]

    def percept_events(self, prefix: str) -> list[tuple[str, str, str, int]]:
        """Percepts added and removed whose literal starts with `prefix`, in the order
        heard: (op, literal, sending component, its incarnation)."""
        with self._lock:
            return [e for e in self.percept_log if e[1].startswith(prefix)]

    def log(self, tail: int = 8000) -> str:
        """The end of the system's output."""
        try:
            return self.output.read_text(encoding="utf-8", errors="replace")[-tail:]
        except OSError:
            return ""

    # -- the outside world -----------------------------------------------------------------
    def file(self, name: str) -> str:
        """A run folder file (broker.url, worldmodel.url, ...), stripped."""
        return (self.run_dir / name).read_text(encoding="utf-8").strip()

    def world(self, object_id: str) -> dict[str, Any] | None:
        """A world model object over its HTTP API (None if there is no such object)."""
        url = f"{self.file('worldmodel.url')}/objects/{quote(object_id, safe='')}"
        if self._token is None:
            self._token = (project_token(self.project_dir),)  # read once
        token = self._token[0]
        headers = {"Authorization": f"Bearer {token}"} if token else {}
        try:
            with urllib.request.urlopen(urllib.request.Request(url, headers=headers),
                                        timeout=5) as resp:
                result: dict[str, Any] = json.loads(resp.read())
                return result
        except urllib.error.HTTPError as exc:
            if exc.code == 404:
                return None
            raise

    def robot_data(self, robot: str, data: Mapping[str, JsonValue]) -> None:
        """Put robot data on the bus (`robot.<robot>.data`) as any bus client could: a
        forged or broken record, to see what the system makes of it."""
        if self._pub is None:
            self._pub = Publisher(endpoints_from_config({}, self.run_dir, nodes=bool(self.node)),
                                  src="procedure")
        self._pub.publish(RobotData(robot=robot, data=dict(data)))

    def link_data(self, robot: str, data: Mapping[str, JsonValue], *, owner: str = "rcl"
                  ) -> None:
        """Put robot data on the bus as the robot's link would: from `owner` (the component
        whose table lists the robot), its live incarnation, proven with the run's key. For
        a broken record from a real link, to see what the validation layer makes of it
        (`robot_data` is a stranger's, refused before it is read)."""
        inc = self.incarnation(owner)
        assert inc, f"no heartbeat from {owner} yet"
        endpoints = endpoints_from_config({}, self.run_dir, nodes=bool(self.node))
        key = self.run_dir / KEY_FILE
        if key.is_file():
            endpoints = endpoints.keyed(key)
        if self._owner_pub is None or self._owner_pub[0] != (owner, inc):
            if self._owner_pub is not None:
                self._owner_pub[1].close()
            self._owner_pub = ((owner, inc), Publisher(endpoints, src=owner, inc=inc))
        self._owner_pub[1].publish(RobotData(robot=robot, data=dict(data)))

    def publish(self, topic: str, payload: Mapping[str, Any]) -> None:
        """Publish a JSON message (QoS 1) on the system's broker, as an outside client
        (with the project's `[broker]` login, if it has one)."""
        try:
            url = project_broker_url(self.project_dir, self.run_dir) or self.file("broker.url")
            publish_json(url, topic, payload, client_id=f"procedure-{os.getpid()}")
        except MrssError as exc:
            raise AssertionError(str(exc)) from None


def _alive(process: psutil.Process) -> bool:
    try:
        return bool(process.is_running() and process.status() != psutil.STATUS_ZOMBIE)
    except psutil.NoSuchProcess:
        return False
