"""The wildfire edge under `mrss supervise`, for fault tests through real processes.

A project is written for each run: the wildfire adapter (`projects/wildfire/events.py`)
and world seed, with the bus proxy, the world model and two events managers — `events`
on the operator topics `mrss/ui/...` with a long retry budget, and `events_short` on
`short/ui/...` with a budget of a second, to see an event given up on. Hang detection is
off in practice (600 missed heartbeats), so a SIGSTOPped component stays stopped until
the test resumes it. The broker is the embedded one, or a URL given (a Mosquitto).

The test watches the bus like any other component: the root's tree (`ctl.tree`: pids,
incarnations), log records, event reports, the plain `percept` topic, and it is the
receiver of the reliable channel "percept" (the reasoner's place; there is no reasoner).
"""

from __future__ import annotations

import json
import os
import shutil
import subprocess
import sys
import threading
import time
from pathlib import Path
from typing import Any

from mrss.bus import BusEndpoints, Publisher, ReliableReceiver, Subscriber
from mrss.edge.mqtt_client import MqttClient, MqttSettings
from mrss.messages import Command, Envelope, EventReport, LogRecord, Percept, SupEvent
from mrss.testing import stop_supervised, wait_until
from mrss.world.access import WorldModelClient

WILDFIRE = Path(__file__).resolve().parents[2] / "projects" / "wildfire"
PROJECT = "edgefaults"

PROJECT_TOML = """\
[project]
name = "{name}"

[supervisor]
strategy = "one_for_one"
intensity = 50
period = 30.0
heartbeat_interval = 0.5
heartbeat_misses = 600

[supervisor.backoff]
initial = 0.02
cap = 0.2
jitter = 0.0

[components.bus]
kind = "bus"
{broker_component}
[components.worldmodel]
kind = "worldmodel"

[components.events]
kind = "events"

[components.events_short]
kind = "events"
topic_prefix = "short/ui"
retry_budget = 1.0

[broker]
{broker_url}reconnect_min = 0.1
reconnect_max = 0.5

[events]
topic_prefix = "mrss/ui"
retry_budget = 300.0
retry_max_delay = 0.5
world_model_timeout = 0.5
{events_extra}
[worldmodel]
seed = "world.json"
{worldmodel_extra}"""


def write_project(projects: Path, broker_url: str | None, worldmodel_extra: str = "",
                  files: dict[str, str] | None = None, events_extra: str = "",
                  tables: str = "") -> Path:
    """The test project under `projects/edgefaults/`, with the wildfire adapter; more
    `[worldmodel]` and `[events]` lines, more tables at the end (`tables`) and project
    files (name -> text) when given."""
    folder = projects / PROJECT
    folder.mkdir(parents=True)
    shutil.copy(WILDFIRE / "events.py", folder / "events.py")
    shutil.copy(WILDFIRE / "world.json", folder / "world.json")
    for name, text in (files or {}).items():
        (folder / name).parent.mkdir(parents=True, exist_ok=True)
        (folder / name).write_text(text)
    broker_component = "" if broker_url else (
        '\n[components.broker]\nkind = "broker"\n')
    (folder / "project.toml").write_text(PROJECT_TOML.format(
        name=PROJECT, broker_component=broker_component,
        broker_url=f'url = "{broker_url}"\n' if broker_url else "",
        worldmodel_extra=worldmodel_extra, events_extra=events_extra) + tables)
    return folder


class SupervisedEdge:
    """One `mrss supervise edgefaults` run and what the test saw of it."""

    def __init__(self, root: Path, broker_url: str | None = None, *,
                 worldmodel_extra: str = "", files: dict[str, str] | None = None,
                 token: str | None = None, events_extra: str = "",
                 tables: str = "") -> None:
        self.root = root
        self.run_dir = root / "run"
        self.run_dir.mkdir()
        write_project(root / "projects", broker_url, worldmodel_extra, files, events_extra,
                      tables)
        self.endpoints = BusEndpoints.ipc(self.run_dir)
        self._lock = threading.Lock()
        self.seen: list[Envelope] = []
        self.reliable: list[Envelope] = []
        self.sub = Subscriber(self.endpoints, prefixes=["sup.tree", "log.", "edge.",
                                                        "percept"])
        self.sub.start(self._record)
        self.pub = Publisher(self.endpoints, src="tester")
        self.receiver = ReliableReceiver(self.endpoints, src="test", channel="percept",
                                         handler=self._record_reliable)
        self._log = (root / "supervise.log").open("w")
        self.proc = subprocess.Popen(
            [sys.executable, "-m", "mrss", "supervise", PROJECT, "--run-dir",
             str(self.run_dir)],
            env={**os.environ, "MRSS_PROJECTS": str(root / "projects")},
            stdout=self._log, stderr=subprocess.STDOUT, start_new_session=True)
        self.world = WorldModelClient(run_dir=self.run_dir, timeout=2.0, token=token)
        self.mqtt: MqttClient | None = None
        self.replies: list[dict[str, Any]] = []

    # ------------------------------------------------------------ observing
    def _record(self, env: Envelope) -> None:
        with self._lock:
            self.seen.append(env)

    def _record_reliable(self, env: Envelope) -> None:
        with self._lock:
            self.reliable.append(env)

    def bodies(self, kind: type[Any]) -> list[Any]:
        with self._lock:
            return [e.body for e in self.seen if isinstance(e.body, kind)]

    def plain_percepts(self, literal: str) -> list[Envelope]:
        """Envelopes of `literal` seen on the plain `percept` topic."""
        with self._lock:
            return [e for e in self.seen
                    if isinstance(e.body, Percept) and e.body.literal == literal]

    def percepts(self, literal: str) -> list[Envelope]:
        """Envelopes of `literal` received on the reliable channel "percept"."""
        with self._lock:
            return [e for e in self.reliable
                    if isinstance(e.body, Percept) and e.body.literal == literal]

    def reports(self, status: str | None = None, *, event_id: str | None = None,
                topic: str | None = None) -> list[EventReport]:
        return [r for r in self.bodies(EventReport)
                if (status is None or r.status == status)
                and (event_id is None or r.event_id == event_id)
                and (topic is None or r.event_topic == topic)]

    def logs(self, component: str, text: str) -> list[LogRecord]:
        return [r for r in self.bodies(LogRecord) if r.component == component
                and text in r.message]

    def children(self, timeout: float = 5.0) -> dict[str, dict[str, Any]]:
        """The root's children now ({} if it did not answer): id -> state, pid, incarnation."""
        before = len(self.bodies(SupEvent))

        def answer() -> list[SupEvent]:
            return [b for b in self.bodies(SupEvent)[before:] if b.event == "tree"]
        self.pub.publish(Command(command="tree"))
        try:
            tree = wait_until(answer, timeout, interval=0.02, message="tree")[-1]
        except AssertionError:
            return {}
        kids = tree.detail["tree"].get("children", [])  # type: ignore[union-attr]
        return {str(k["id"]): k for k in kids}

    def child(self, component: str) -> dict[str, Any]:
        """The root's record of a running component (waits for one)."""
        def running() -> dict[str, Any] | None:
            kid = self.children().get(component)
            return kid if kid and kid["state"] == "running" and kid["pid"] else None
        found: dict[str, Any] = wait_until(running, 60, interval=0.05,
                                           message=f"{component} running")
        return found

    def pid(self, component: str) -> int:
        return int(self.child(component)["pid"])

    def incarnation(self, component: str) -> int:
        return int(self.child(component)["incarnation"])

    def log_text(self) -> str:
        self._log.flush()
        return (self.root / "supervise.log").read_text(errors="replace")

    # ------------------------------------------------------------ acting
    def broker_url(self) -> str:
        url = (self.run_dir / "broker.url")
        return url.read_text().strip() if url.is_file() else ""

    def connect_mqtt(self, url: str) -> MqttClient:
        """The operator's MQTT client (QoS 1), listening to every reply topic."""
        client = MqttClient(MqttSettings.from_config({"url": url, "reconnect_min": 0.1,
                                                      "reconnect_max": 0.5}),
                            client_id=f"operator-{os.getpid()}-{id(self)}")

        def on_reply(topic: str, payload: bytes) -> None:
            with self._lock:
                self.replies.append({"reply_topic": topic, **json.loads(payload)})
        client.subscribe("+/ui/+/reply", on_reply)
        client.start()
        assert client.wait_subscribed(30), "operator client not subscribed"
        self.mqtt = client
        return client

    def publish(self, topic: str, payload: dict[str, Any]) -> None:
        assert self.mqtt is not None
        assert self.mqtt.publish(topic, json.dumps(payload).encode(), qos=1)

    def reply(self, event_id: str) -> list[dict[str, Any]]:
        with self._lock:
            return [r for r in self.replies if r.get("id") == event_id]

    def wait_ready(self, timeout: float = 60.0) -> None:
        """Every component heartbeats and each events manager turns MQTT into percepts."""
        def up() -> bool:
            if self.proc.poll() is not None:
                raise AssertionError(f"mrss supervise exited:\n{self.log_text()}")
            kids = self.children(timeout=1.0)
            return all(kids.get(c, {}).get("state") == "running"
                       for c in ("worldmodel", "events", "events_short")) \
                and (self.run_dir / "worldmodel.url").is_file() \
                and (self.mqtt is not None or bool(self.broker_url()))
        wait_until(up, timeout, interval=0.05, message="components up")
        if self.mqtt is None:
            self.connect_mqtt(self.broker_url())
        for n, prefix in enumerate(("mrss/ui", "short/ui")):
            # Until the manager's subscription is in place a message may pass it by: the
            # probe goes again every 0.5 s until its percept arrives (looked for at once).
            sent = [-1.0]

            def answered(prefix: str = prefix, n: int = n, sent: list[float] = sent) -> bool:
                if self.percepts(f"goal_cancelled(probe{n})"):
                    return True
                if time.monotonic() - sent[0] >= 0.5:
                    self.publish(f"{prefix}/cancel", {"goal": f"probe{n}",
                                                      "id": f"probe-{n}"})
                    sent[0] = time.monotonic()
                return False
            wait_until(answered, timeout, interval=0.01,
                       message=f"{prefix} events reaching the percept channel\n"
                               f"{self.log_text()[-3000:]}")

    def signal(self, component: str, sig: int) -> int:
        pid = self.pid(component)
        os.kill(pid, sig)
        return pid

    def close(self) -> None:
        """SIGTERM the root supervisor (orderly stop), kill whatever is left."""
        try:
            if self.mqtt is not None:
                self.mqtt.stop()
            stop_supervised(self.proc)
        finally:
            self.receiver.close()
            self.sub.close()
            self.pub.close()
            self._log.close()
