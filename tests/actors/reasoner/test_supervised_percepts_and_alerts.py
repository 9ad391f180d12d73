"""Through real processes under `mrss supervise` (bus proxy, events manager, reasoner) and
a real Mosquitto, whose log (every packet) shows when the events manager acknowledges:

- a goal that fails past its retry budget reaches the operator: `agent.gave_up.<agent>`
  on the bus, with its reason and last cause, raised by the dashboard's alerts model;
- a percept the MQTT broker was not told of (no PUBACK) until the reasoner has it in its
  ledger: the events manager, or the reasoner, killed inside that window (the reasoner
  SIGSTOPped, the event handled and reported accepted) loses nothing, and the order is
  acted on exactly once.
"""

from __future__ import annotations

import getpass
import json
import os
import re
import shutil
import signal
import socket
import subprocess
import sys
import tempfile
import threading
from collections.abc import Iterator
from pathlib import Path
from typing import Any

import pytest

from mrss.bus import BusEndpoints, Publisher, Subscriber
from mrss.edge.mqtt_client import MqttClient, MqttSettings
from mrss.messages import (
    Command,
    Envelope,
    EventReport,
    GiveUpReason,
    GoalGaveUp,
    LogRecord,
    SupEvent,
)
from mrss.testing import find_mosquitto, free_port, stop_supervised, wait_until
from mrss.tui.models.alerts import AlertKind, AlertsModel
from tests.mosquitto import require_mosquitto

pytestmark = pytest.mark.slow

PROJECT = "agentalerts"
CLIENT = f"mrss-{PROJECT}-events"  # the events manager's MQTT client id

PROJECT_TOML = """\
[project]
name = "agentalerts"

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

[components.events]
kind = "events"

[components.reasoner]
kind = "reasoner"
lease = 0.3
adopt_wait = 0.2

[broker]
url = "{url}"
reconnect_min = 0.1
reconnect_max = 0.5
"""

EVENTS = """\
from mrss.api import ExternalAdapter, Field, JsonMapping


class Orders(ExternalAdapter):
    def start(self) -> None:
        self.map_json("ops/order", JsonMapping("order", Field("goal", "atom")))
        self.map_json("ops/goal", JsonMapping("goal", Field("goal", "atom")))
"""

# An order is acted on (a log line) and its percept consumed. A goal has no RCL to run
# its action: each try fails on the 0.3 s lease (transient); two tries, then given up.
AGENT = """\
max_tries(2).
+order(G)[source(percept)] <- .print("acting on order ", G); -order(G)[source(percept)].
+goal(G)[source(percept)] <- !reach(G, 1).
+!reach(G, N) <- move(uav1, G).
-!reach(G, N)[error(E)] : max_tries(M) & N < M <- !reach(G, N + 1).
-!reach(G, N)[error(E)] <- give_up(reach(G), budget_exhausted, E).
"""


class LoggingMosquitto:
    """Mosquitto on a free port, logging every packet to a file."""

    def __init__(self, folder: Path, binary: str) -> None:
        self.port = free_port()
        self.log = folder / "mosquitto.log"
        conf = folder / "mosquitto.conf"
        conf.write_text(f"user {getpass.getuser()}\nallow_anonymous true\nlog_type all\n"
                        f"log_dest file {self.log}\nlistener {self.port} 127.0.0.1\n")
        self.proc = subprocess.Popen([binary, "-c", str(conf)], stdout=subprocess.DEVNULL,
                                     stderr=subprocess.DEVNULL)

        def accepting() -> bool:
            try:
                with socket.create_connection(("127.0.0.1", self.port), timeout=0.2):
                    return True
            except OSError:
                return False
        wait_until(accepting, 20, interval=0.02, message="mosquitto accepting")

    @property
    def url(self) -> str:
        return f"mqtt://127.0.0.1:{self.port}"

    def text(self) -> str:
        return self.log.read_text(errors="replace") if self.log.is_file() else ""

    def sent_to_events(self, topic: str) -> list[int]:
        """The packet ids of the messages on `topic` the broker sent the events manager."""
        return [int(m) for m in re.findall(
            rf"Sending PUBLISH to {CLIENT} \(d\d, q1, r\d, m(\d+), '{re.escape(topic)}'",
            self.text())]

    def pubacks_from_events(self) -> list[int]:
        return [int(m) for m in re.findall(rf"Received PUBACK from {CLIENT} \(Mid: (\d+)",
                                           self.text())]

    def stop(self) -> None:
        self.proc.terminate()
        self.proc.wait(timeout=20)


class Run:
    """One `mrss supervise agentalerts` and what the test saw on the bus."""

    def __init__(self, root: Path, broker: LoggingMosquitto) -> None:
        self.root, self.broker = root, broker
        folder = root / "projects" / PROJECT
        folder.mkdir(parents=True)
        (folder / "project.toml").write_text(PROJECT_TOML.format(url=broker.url))
        (folder / "events.py").write_text(EVENTS)
        (folder / "agent.asl").write_text(AGENT)
        self.run_dir = root / "run"
        self.run_dir.mkdir()
        endpoints = BusEndpoints.ipc(self.run_dir)
        self._lock = threading.Lock()
        self.seen: list[Envelope] = []
        self.sub = Subscriber(endpoints, prefixes=["sup.tree", "log.", "edge.", "agent."])
        self.sub.start(self._keep)
        self.pub = Publisher(endpoints, src="tester")
        self._log = (root / "supervise.log").open("w")
        self.proc = subprocess.Popen(
            [sys.executable, "-m", "mrss", "supervise", PROJECT, "--run-dir",
             str(self.run_dir)], env={**os.environ, "MRSS_PROJECTS": str(root / "projects")},
            stdout=self._log, stderr=subprocess.STDOUT, start_new_session=True)
        self.mqtt = MqttClient(MqttSettings.from_config({"url": broker.url}),
                               client_id=f"operator-{os.getpid()}")
        self.mqtt.start()
        assert self.mqtt.wait_connected(30)

    def _keep(self, env: Envelope) -> None:
        with self._lock:
            self.seen.append(env)

    def envelopes(self, kind: type[Any]) -> list[Envelope]:
        with self._lock:
            return [e for e in self.seen if isinstance(e.body, kind)]

    def acted(self, goal: str) -> int:
        """How often the reasoner acted on order `goal` (its plan's log line)."""
        return sum(1 for e in self.envelopes(LogRecord) if e.body.component == "reasoner"
                   and e.body.message.endswith(f"acting on order {goal}"))

    def accepted(self, event_id: str) -> bool:
        return any(e.body.status == "accepted" and e.body.event_id == event_id
                   for e in self.envelopes(EventReport))

    def child(self, name: str) -> dict[str, Any]:
        """The root's record of `name` once running (pid, incarnation)."""
        def running() -> dict[str, Any] | None:
            before = len(self.envelopes(SupEvent))
            self.pub.publish(Command(command="tree"))
            try:
                tree = wait_until(lambda: [e.body for e in self.envelopes(SupEvent)[before:]
                                           if e.body.event == "tree"], 2, interval=0.02)
            except AssertionError:
                return None
            kids = {k["id"]: k for k in tree[-1].detail["tree"]["children"]}
            kid = kids.get(name)
            return kid if kid and kid["state"] == "running" and kid["pid"] else None
        found: dict[str, Any] = wait_until(running, 60, interval=0.05,
                                           message=f"{name} running\n{self.log_text()}")
        return found

    def order(self, goal: str, topic: str = "ops/order") -> None:
        assert self.mqtt.publish(topic, json.dumps({"goal": goal, "id": f"id-{goal}"}), qos=1)

    def wait_ready(self) -> None:
        """The order path works end to end: a probe, sent until the reasoner acts on it."""
        for name in ("events", "reasoner"):
            self.child(name)
        sent = [0]

        def acted() -> bool:
            sent[0] += 1
            if sent[0] % 25 == 1:
                self.order(f"probe{sent[0]}")
            return any(self.acted(f"probe{n}") for n in range(1, sent[0] + 1))
        wait_until(acted, 60, interval=0.02, message=f"orders acted on\n{self.log_text()}")

    def log_text(self) -> str:
        self._log.flush()
        return (self.root / "supervise.log").read_text(errors="replace")[-4000:]

    def close(self) -> None:
        try:
            self.mqtt.stop()
            stop_supervised(self.proc)
        finally:
            self.sub.close()
            self.pub.close()
            self._log.close()


@pytest.fixture()
def run() -> Iterator[Run]:
    binary = require_mosquitto(find_mosquitto(), "the PUBACK window test")
    root = Path(tempfile.mkdtemp(prefix="mrss-agal-"))
    broker = LoggingMosquitto(root, binary)
    system = Run(root, broker)
    try:
        system.wait_ready()
        yield system
    finally:
        system.close()
        broker.stop()
        shutil.rmtree(root, ignore_errors=True)


def test_a_goal_past_its_retry_budget_reaches_the_operator_as_an_alert(run: Run) -> None:
    run.order("g1", topic="ops/goal")
    env = wait_until(lambda: run.envelopes(GoalGaveUp), 60,
                     message=f"the give-up on the bus\n{run.log_text()}")[0]
    assert env.src == "reasoner" and env.topic == "agent.gave_up.reasoner"
    assert (env.body.agent, env.body.goal, env.body.reason, env.body.cause) == (
        "reasoner", "reach(g1)", GiveUpReason.BUDGET_EXHAUSTED, "transient")
    # the dashboard's alerts model, fed what the bus carried
    alerts = AlertsModel()
    [alert] = alerts.apply(env)
    assert alert.kind is AlertKind.GOAL_GAVE_UP and alert.severe
    assert alert.line() == ("goal given up: reasoner: reach(g1) "
                            "budget_exhausted (last cause: transient)")


def _held_in_the_window(run: Run, goal: str) -> int:
    """Stop the reasoner, send order `goal`, wait until the events manager has handled
    it (reported accepted): the window. The broker has had no PUBACK for it."""
    os.kill(run.child("reasoner")["pid"], signal.SIGSTOP)
    run.order(goal)
    wait_until(lambda: run.accepted(f"id-{goal}"), 60, message="the order handled")
    [mid] = wait_until(lambda: run.broker.sent_to_events("ops/order")[-1:], 10,
                       message="the broker's packet id")
    assert mid not in run.broker.pubacks_from_events(), \
        "acknowledged to MQTT before the reasoner had the percept"
    return mid


def test_an_events_manager_killed_before_the_reasoner_has_the_percept_loses_nothing(
        run: Run) -> None:
    events = run.child("events")
    reasoner_pid = run.child("reasoner")["pid"]
    try:
        mid = _held_in_the_window(run, "o1")
        os.kill(events["pid"], signal.SIGKILL)  # inside the window
        wait_until(lambda: run.child("events")["incarnation"] > events["incarnation"], 60,
                   interval=0.05, message="a new events manager")
    finally:
        os.kill(reasoner_pid, signal.SIGCONT)
    wait_until(lambda: run.acted("o1"), 60,
               message=f"the order, delivered again by the broker\n{run.log_text()}")
    run.order("o2")  # later: once it is acted on, a second o1 would have been too
    wait_until(lambda: run.acted("o2"), 60, message="a later order")
    wait_until(lambda: mid in run.broker.pubacks_from_events(), 30,
               message="acknowledged to MQTT by the new events manager")
    assert run.acted("o1") == 1


def test_a_reasoner_killed_before_it_has_the_percept_loses_nothing(run: Run) -> None:
    reasoner = run.child("reasoner")
    try:
        mid = _held_in_the_window(run, "o3")
    finally:
        os.kill(reasoner["pid"], signal.SIGKILL)  # stopped, never took the percept
    wait_until(lambda: run.child("reasoner")["incarnation"] > reasoner["incarnation"], 60,
               interval=0.05, message="a new reasoner")
    wait_until(lambda: run.acted("o3"), 60,
               message=f"the order, sent again to the new reasoner\n{run.log_text()}")
    wait_until(lambda: mid in run.broker.pubacks_from_events(), 30,
               message="acknowledged to MQTT once the new reasoner has it")
    run.order("o4")
    wait_until(lambda: run.acted("o4"), 60, message="a later order")
    assert run.acted("o3") == 1
