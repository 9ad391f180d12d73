"""No silent drops at the edge, through real processes under `mrss supervise`.

Issue 9, finding 2: after a world model restart the wildfire adapter posted areas to
the dead incarnation's port, and the operator's goal was dropped with only a log line.
Here the world model is SIGKILLed and SIGSTOPped, the events manager is SIGSTOPped and
SIGKILLed, and the MQTT broker is restarted, while the operator publishes goals; every
goal ends as exactly one percept on the reliable channel, or as a report to the
operator (reply topic) and on the bus.
"""

from __future__ import annotations

import getpass
import shutil
import signal
import subprocess
import tempfile
from collections.abc import Iterator
from pathlib import Path

import pytest

from mrss.testing import find_mosquitto, free_port, wait_until
from tests.mosquitto import require_mosquitto

from .supervised_edge import SupervisedEdge

pytestmark = pytest.mark.slow

CENTER = [-35.3625, 149.1650]


def area(goal: str, priority: int, event_id: str | None = None) -> dict[str, object]:
    payload: dict[str, object] = {"goal": goal, "priority": priority, "center": CENTER,
                                  "radius": 100}
    if event_id:
        payload["id"] = event_id
    return payload


@pytest.fixture()
def edge() -> Iterator[SupervisedEdge]:
    """The wildfire edge with the embedded broker, ready for operator goals."""
    root = Path(tempfile.mkdtemp(prefix="mrss-edgef-"))
    run = SupervisedEdge(root)
    try:
        run.wait_ready()
        yield run
    finally:
        run.close()
        shutil.rmtree(root, ignore_errors=True)


def test_operator_goal_after_a_world_model_kill_is_stored_in_the_new_incarnation(
        edge: SupervisedEdge) -> None:
    url_before = (edge.run_dir / "worldmodel.url").read_text()
    first = edge.incarnation("worldmodel")
    edge.signal("worldmodel", signal.SIGKILL)
    wait_until(lambda: edge.incarnation("worldmodel") > first, 60, interval=0.05,
               message="a new world model incarnation")

    edge.publish("mrss/ui/area", area("a1", 2, "op-1"))

    got = wait_until(lambda: edge.percepts("area_goal_received(a1,2)"), 60,
                     message=f"the area goal percept\n{edge.log_text()[-3000:]}")
    stored = edge.world.get("a1")
    assert stored is not None and stored["kind"] == "area"
    assert stored["attributes"]["priority"] == 2
    # The new incarnation serves where the old one did: clients that kept the URL work.
    assert (edge.run_dir / "worldmodel.url").read_text() == url_before
    assert got[0].src == "events"
    # The viewers' copy on the plain topic carries the same envelope id.
    plain = wait_until(lambda: edge.plain_percepts("area_goal_received(a1,2)"), 30,
                       message="the plain copy")
    assert [e.id for e in plain] == [got[0].id]
    accepted = wait_until(lambda: edge.reports("accepted", event_id="op-1"), 30,
                          message="the accepted report")
    assert accepted[0].detail == {"goal": "a1"}


def test_operator_goal_waits_for_a_hung_world_model_and_is_delivered_when_it_resumes(
        edge: SupervisedEdge) -> None:
    edge.signal("worldmodel", signal.SIGSTOP)
    try:
        edge.publish("mrss/ui/area", area("a2", 3, "op-2"))
        wait_until(lambda: edge.logs("events", "waits for a dependency"), 60,
                   message="the events manager retrying")
        assert not edge.percepts("area_goal_received(a2,3)")
    finally:
        edge.signal("worldmodel", signal.SIGCONT)

    wait_until(lambda: edge.percepts("area_goal_received(a2,3)"), 60,
               message=f"the goal once the world model resumed\n{edge.log_text()[-3000:]}")
    report = wait_until(lambda: edge.reports("accepted", event_id="op-2"), 30,
                        message="the accepted report")[0]
    assert report.attempts > 1
    assert edge.world.get("a2") is not None
    assert not edge.reply("op-2")  # accepted events are not answered by default


def test_operator_goal_the_world_model_cannot_take_in_time_is_reported_to_the_operator(
        edge: SupervisedEdge) -> None:
    edge.signal("worldmodel", signal.SIGSTOP)
    try:
        edge.publish("short/ui/area", area("a3", 1, "op-3"))
        reply = wait_until(lambda: edge.reply("op-3"), 60,
                           message=f"the reply to the operator\n{edge.log_text()[-3000:]}")[0]
        assert reply["reply_topic"] == "short/ui/area/reply"
        assert reply["status"] == "failed" and reply["goal"] == "a3"
        assert "unavailable" in reply["reason"] and reply["attempts"] >= 2
        failed = wait_until(lambda: edge.reports("failed", event_id="op-3"), 30,
                            message="the failure on the bus")[0]
        assert failed.event_topic == "short/ui/area" and failed.component == "events_short"
        wait_until(lambda: [r for r in edge.logs("events_short", "event_failed")
                            if r.level == "ERROR"], 30, message="the dashboard's log line")
    finally:
        edge.signal("worldmodel", signal.SIGCONT)

    # A bad payload is not retried: it is answered at once.
    edge.publish("mrss/ui/area", {"goal": "Not An Atom", "id": "op-bad", "center": CENTER,
                                  "radius": 50})
    bad = wait_until(lambda: edge.reply("op-bad"), 60, message="the rejection")[0]
    assert bad["status"] == "rejected" and bad["attempts"] == 1
    # Events are handled in order: once a later goal is through, a3 had its outcome.
    edge.publish("short/ui/area", area("a4", 1, "op-4"))
    wait_until(lambda: edge.percepts("area_goal_received(a4,1)"), 60, message="a later goal")
    assert not edge.percepts("area_goal_received(a3,1)")
    assert not edge.plain_percepts("area_goal_received(a3,1)")


# -- redeliveries by the broker (Mosquitto: the embedded amqtt keeps a message it sent
# -- for 5 s at most, and does not send it again to a resumed session; docs/edges.md) --

class PersistentMosquitto:
    """A Mosquitto with on-disk persistence, stoppable and restartable on one port."""

    def __init__(self, folder: Path, binary: str) -> None:
        self.binary = binary
        self.port = free_port()
        self.conf = folder / "mosquitto.conf"
        self.conf.write_text(
            f"user {getpass.getuser()}\npersistence true\npersistence_location {folder}/\n"
            f"allow_anonymous true\nlog_type error\nlistener {self.port} 127.0.0.1\n")
        self.proc: subprocess.Popen[bytes] | None = None

    @property
    def url(self) -> str:
        return f"mqtt://127.0.0.1:{self.port}"

    def start(self) -> None:
        import socket

        self.proc = subprocess.Popen([self.binary, "-c", str(self.conf)],
                                     stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)

        def accepting() -> bool:
            try:
                with socket.create_connection(("127.0.0.1", self.port), timeout=0.2):
                    return True
            except OSError:
                return False
        wait_until(accepting, 20, interval=0.02, message="mosquitto accepting")

    def stop(self) -> None:
        """SIGTERM: Mosquitto writes its sessions (and messages in flight) to disk."""
        if self.proc is not None:
            self.proc.terminate()
            self.proc.wait(timeout=20)
            self.proc = None


@pytest.fixture()
def mosquitto_edge() -> Iterator[tuple[SupervisedEdge, PersistentMosquitto]]:
    binary = require_mosquitto(find_mosquitto(), "the redelivery test")
    root = Path(tempfile.mkdtemp(prefix="mrss-edgem-"))
    (root / "broker").mkdir()
    broker = PersistentMosquitto(root / "broker", binary)
    broker.start()
    run = SupervisedEdge(root, broker_url=broker.url)
    try:
        run.connect_mqtt(broker.url)
        run.wait_ready()
        yield run, broker
    finally:
        run.close()
        broker.stop()
        shutil.rmtree(root, ignore_errors=True)


def test_a_goal_redelivered_by_the_broker_is_one_percept(
        mosquitto_edge: tuple[SupervisedEdge, PersistentMosquitto]) -> None:
    edge, broker = mosquitto_edge
    literal = "area_goal_received(a5,2)"
    edge.signal("worldmodel", signal.SIGSTOP)
    try:
        edge.publish("mrss/ui/area", area("a5", 2))  # no id: known by its content
        wait_until(lambda: [r for r in edge.logs("events", "waits for a dependency")
                            if "area" in r.message], 60, message="the goal in hand")
        assert edge.mqtt is not None
        edge.mqtt.stop()
        broker.stop()  # the goal is in flight, unacknowledged, in the broker's session
    finally:
        edge.signal("worldmodel", signal.SIGCONT)
    # The percept goes out; its acknowledgement to the (stopped) broker is lost.
    wait_until(lambda: edge.percepts(literal), 60, message="the goal's percept")

    broker.start()  # from disk: the session still holds the goal, sent again with DUP
    wait_until(lambda: edge.reports("duplicate", topic="mrss/ui/area"), 60,
               message=f"the redelivery recognised\n{edge.log_text()[-3000:]}")
    edge.connect_mqtt(broker.url)
    edge.publish("mrss/ui/area", area("a6", 1))
    wait_until(lambda: edge.percepts("area_goal_received(a6,1)"), 60, message="a later goal")
    assert len(edge.percepts(literal)) == 1
    assert len(edge.plain_percepts(literal)) == 1


def test_operator_goal_in_the_hands_of_a_killed_events_manager_is_delivered_by_the_next(
        mosquitto_edge: tuple[SupervisedEdge, PersistentMosquitto]) -> None:
    edge, _ = mosquitto_edge
    first = edge.incarnation("events")
    edge.signal("worldmodel", signal.SIGSTOP)
    try:
        edge.publish("mrss/ui/area", area("a7", 2, "op-7"))
        wait_until(lambda: [r for r in edge.logs("events", "waits for a dependency")
                            if "area" in r.message], 60, message="the goal in hand")
        edge.signal("events", signal.SIGKILL)  # it never acknowledged the goal
        wait_until(lambda: edge.incarnation("events") > first, 60, interval=0.05,
                   message="a new events manager")
    finally:
        edge.signal("worldmodel", signal.SIGCONT)

    got = wait_until(lambda: edge.percepts("area_goal_received(a7,2)"), 60,
                     message=f"the goal from the broker's session\n{edge.log_text()[-3000:]}")
    assert got[0].inc > first
    # Sent again while the new incarnation was down? Still one percept.
    edge.publish("mrss/ui/area", area("a7", 2, "op-7"))
    wait_until(lambda: edge.reports("duplicate", event_id="op-7"), 60,
               message="the repeat recognised")
    edge.publish("mrss/ui/area", area("a8", 1, "op-8"))
    wait_until(lambda: edge.percepts("area_goal_received(a8,1)"), 60, message="a later goal")
    assert len(edge.percepts("area_goal_received(a7,2)")) == 1
