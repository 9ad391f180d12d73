"""The robots an events manager knows: the project's (its RCL's robots tables), or
`[events] robots`; a `robot` field naming any other is refused at the door."""

from __future__ import annotations

import json
import threading
from pathlib import Path

import pytest

from mrss.actors.events.service import ExternalEventsManager
from mrss.edge.mqtt_client import MqttClient, MqttSettings
from mrss.errors import ConfigError
from mrss.messages import Message, Percept
from mrss.runtime.edge import project_robots
from mrss.testing import BrokerInfo, wait_until

WILDFIRE = Path(__file__).resolve().parents[3] / "projects" / "wildfire"


class Recorder:
    def __init__(self) -> None:
        self.messages: list[Message] = []
        self.lock = threading.Lock()

    def publish(self, msg: Message, topic: str | None = None) -> str:
        with self.lock:
            self.messages.append(msg)
        return "id"

    def literals(self) -> list[str]:
        with self.lock:
            return [m.literal for m in self.messages if isinstance(m, Percept)]


def test_a_projects_robots_are_its_rcls_robots_tables(tmp_path: Path) -> None:
    assert project_robots(WILDFIRE) == {"uav1", "uav2", "uav3", "ugv1", "ugv2"}
    assert project_robots(tmp_path) == frozenset()  # no project.toml: none known


@pytest.mark.parametrize(("events", "known"), [
    ({}, "uav1, uav2, uav3, ugv1, ugv2"),       # the RCL's robots
    ({"robots": ["ugv1"]}, "ugv1"),             # [events] robots
])
def test_the_wildfire_adapter_refuses_teleop_of_a_robot_the_project_has_not(
        mqtt_broker: BrokerInfo, events: dict[str, object], known: str) -> None:
    recorder, manager = Recorder(), ExternalEventsManager()
    replies: list[dict[str, object]] = []
    sender = MqttClient(MqttSettings.from_url(mqtt_broker.url), client_id="robots-sender")
    sender.subscribe("mrss/ui/teleop/reply", lambda _t, p: replies.append(json.loads(p)))
    try:
        manager.run(WILDFIRE, {"broker": {"url": mqtt_broker.url}, "events": {
            "world_model": "http://127.0.0.1:9", "client_id": f"robots-{len(known)}",
            **events}}, recorder)
        assert manager.mqtt is not None and manager.mqtt.wait_subscribed(20)
        sender.start()
        assert sender.wait_subscribed(20)
        for robot in ("ghost", "ugv1"):
            assert sender.publish("mrss/ui/teleop", json.dumps(
                {"robot": robot, "on": True, "id": robot}).encode(), qos=1)
        wait_until(lambda: "teleop(ugv1,on)" in recorder.literals() and replies, 20,
                   message="the percept of ugv1 and the answer about the ghost")
        assert [r["id"] for r in replies] == ["ghost"] and replies[0]["status"] == "rejected"
        assert f"unknown robot 'ghost' (known: {known})" in str(replies[0]["reason"])
        assert not [p for p in recorder.literals() if "ghost" in p]
    finally:
        sender.stop()
        manager.stop()


def test_events_robots_must_be_a_list_of_ids(mqtt_broker: BrokerInfo) -> None:
    with pytest.raises(ConfigError, match="must be a list of robot ids"):
        ExternalEventsManager().run(WILDFIRE, {"events": {"robots": "ugv1",
                                                          "world_model": "http://x"}},
                                    Recorder())
