"""The embedded broker keeps persistent sessions across a SIGKILL, through real processes.

`mrss supervise` runs the edge project (tests/edge/supervised_edge.py) with the embedded
broker, which is Mosquitto here (engine "auto"). A persistent subscriber goes away,
QoS 1 messages are published to it and acknowledged, the broker is SIGKILLed (the
Mosquitto process itself, or the component that runs it) and restarted by the
supervisor, and the subscriber gets every message. The events manager likewise gets an
operator's goal published after the restart while it was away.

Durability point (docs/edges.md, `mrss.actors.broker.mosquitto`): Mosquitto has written a
message by the time it acknowledges anything received after it, so each test waits for
one more acknowledged publication before the kill (docs/edges.md gives the measured
loss without it).
"""

from __future__ import annotations

import os
import shutil
import signal
import tempfile
from collections.abc import Iterator
from pathlib import Path

import paho.mqtt.client as mqtt
import psutil
import pytest

from mrss.testing import find_mosquitto, process_gone, wait_until
from tests.edge.supervised_edge import SupervisedEdge
from tests.mosquitto import require_mosquitto

pytestmark = pytest.mark.slow


@pytest.fixture()
def edge() -> Iterator[SupervisedEdge]:
    require_mosquitto(find_mosquitto(), "the embedded Mosquitto test")
    root = Path(tempfile.mkdtemp(prefix="mrss-brokerp-"))
    run = SupervisedEdge(root)
    try:
        run.wait_ready()
        yield run
    finally:
        run.close()
        shutil.rmtree(root, ignore_errors=True)


def mosquitto_pid(edge: SupervisedEdge) -> int:
    """The Mosquitto child of the broker component."""
    kids = psutil.Process(edge.pid("broker")).children()
    found = [k.pid for k in kids if k.name() == "mosquitto"]
    assert len(found) == 1, f"broker component children: {kids}"
    return found[0]


def client(url: str, client_id: str, clean: bool) -> mqtt.Client:
    host, port = url.removeprefix("mqtt://").rsplit(":", 1)
    c = mqtt.Client(mqtt.CallbackAPIVersion.VERSION2, client_id=client_id,
                    clean_session=clean)
    c.reconnect_delay_set(0.1, 0.5)
    c.connect(host, int(port))
    c.loop_start()
    wait_until(c.is_connected, 30, message=f"{client_id} connected")
    return c


def publish_acknowledged(c: mqtt.Client, topic: str, payload: str) -> None:
    info = c.publish(topic, payload, qos=1)
    info.wait_for_publish(30)
    assert info.is_published(), f"{payload} not acknowledged"


def kill_broker(edge: SupervisedEdge, target: str) -> None:
    """SIGKILL the Mosquitto process or the component; wait for the next incarnation."""
    first, old = edge.incarnation("broker"), mosquitto_pid(edge)
    os.kill(old if target == "mosquitto" else edge.pid("broker"), signal.SIGKILL)
    wait_until(lambda: process_gone(old), 30, message="the old mosquitto gone")
    wait_until(lambda: edge.incarnation("broker") > first, 60, interval=0.05,
               message=f"a new broker incarnation\n{edge.log_text()[-3000:]}")


@pytest.mark.parametrize("target", ["mosquitto", "component"])
def test_a_persistent_session_and_its_queued_messages_survive_a_broker_kill(
        edge: SupervisedEdge, target: str) -> None:
    url = edge.broker_url()
    got: list[bytes] = []
    sub = client(url, "persistent-sub", clean=False)
    sub.subscribe("persist/#", qos=1)
    wait_until(lambda: (edge.run_dir / "broker" / "mosquitto.db").is_file(), 30,
               message="the session written to disk")
    sub.disconnect()
    sub.loop_stop()
    pub = client(url, "publisher", clean=True)
    sent = [f"m{i}" for i in range(20)]
    for payload in sent:
        publish_acknowledged(pub, "persist/x", payload)
    publish_acknowledged(pub, "other/marker", "after")  # the durability point
    pub.disconnect()
    pub.loop_stop()

    kill_broker(edge, target)

    assert edge.broker_url() == url  # the same port again
    sub = mqtt.Client(mqtt.CallbackAPIVersion.VERSION2, client_id="persistent-sub",
                      clean_session=False)
    sub.on_message = lambda _c, _u, m: got.append(m.payload)
    host, port = url.removeprefix("mqtt://").rsplit(":", 1)
    sub.connect(host, int(port))
    sub.loop_start()
    try:
        wait_until(lambda: len(got) >= len(sent), 30,
                   message=f"the queued messages, got {got}")
    finally:
        sub.disconnect()
        sub.loop_stop()
    assert [g.decode() for g in got] == sent


def test_the_events_manager_gets_a_goal_published_while_it_was_away_over_a_broker_kill(
        edge: SupervisedEdge) -> None:
    """Its session (QoS 1 subscription) comes back from disk: a goal published after the
    restart, while the events manager was stopped, waits in it."""
    edge.signal("events", signal.SIGSTOP)
    try:
        kill_broker(edge, "mosquitto")
        operator = client(edge.broker_url(), "operator-after-restart", clean=True)
        try:
            publish_acknowledged(operator, "mrss/ui/area", '{"goal": "b1", "priority": 2, '
                                 '"center": [-35.3625, 149.165], "radius": 100, '
                                 '"id": "op-b1"}')
        finally:
            operator.disconnect()
            operator.loop_stop()
    finally:
        edge.signal("events", signal.SIGCONT)
    wait_until(lambda: edge.percepts("area_goal_received(b1,2)"), 60,
               message=f"the goal from the restored session\n{edge.log_text()[-3000:]}")
