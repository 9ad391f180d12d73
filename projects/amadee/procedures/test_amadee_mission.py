"""End-to-end procedure: `mrss supervise amadee` as a real process, driven like the
mission support would drive it over MQTT.

A legal drive moves the rover and a sample is taken where it stops; a drive whose path
crosses the salt marsh (its destination lies beyond it, outside the zone) is refused by
the reasoner with the rule named, the verdict is in the world model for the operator,
and the rover does not move. Every verdict also reaches the operator on mrss/ui/verdict.
A crew member's position, sent as telemetry on mrss/ui/crew, keeps the rover's next
drive away from her.
The simulator runs 20 times faster than real time.
"""

from __future__ import annotations

import json
import threading
from pathlib import Path
from typing import Any

import pytest
from paho.mqtt import client as mqtt
from paho.mqtt.enums import CallbackAPIVersion

from mrss.api import distance_m, project_broker_url
from mrss.api.testing import RunningProject

PROJECT = Path(__file__).resolve().parent.parent
SITE = (39.7705, 44.8000)          # 55 m north of the habitat, in the open
BEYOND_MARSH = (39.7725, 44.8010)  # north of the salt marsh: the straight path crosses it


def position(system: RunningProject) -> tuple[float, float] | None:
    found = (system.world("rover1") or {}).get("position") or {}
    return (found["lat"], found["lon"]) if "lat" in found else None


def verdict(system: RunningProject, goal: str) -> dict[str, object] | None:
    found = system.world(f"verdict_{goal}")
    return None if found is None else dict(found["attributes"])


class Operator:
    """The mission support's side: what arrives on the verdict topic."""

    def __init__(self, broker_url: str) -> None:
        host, _, port = broker_url.rsplit("/", 1)[-1].rpartition(":")
        self.received: list[tuple[str, bytes | bytearray]] = []
        self.subscribed = threading.Event()
        self.client = mqtt.Client(CallbackAPIVersion.VERSION2, client_id="operator")
        self.client.on_connect = lambda c, *_: c.subscribe("mrss/ui/verdict", qos=1)
        self.client.on_subscribe = lambda *_: self.subscribed.set()
        self.client.on_message = lambda _c, _u, m: self.received.append((m.topic, m.payload))
        self.client.connect(host, int(port))
        self.client.loop_start()

    def verdicts(self, goal: str) -> list[dict[str, Any]]:
        found = [json.loads(payload) for topic, payload in list(self.received)
                 if topic == "mrss/ui/verdict"]
        return [v for v in found if v["goal"] == goal]

    def verdict(self, goal: str) -> dict[str, Any] | None:
        return next(iter(self.verdicts(goal)), None)

    def close(self) -> None:
        self.client.disconnect()
        self.client.loop_stop()


@pytest.mark.slow
def test_legal_requests_move_the_rover_and_an_illegal_one_is_refused(tmp_path: Path) -> None:
    with RunningProject(PROJECT, tmp_path / "run", env={"MRSS_SIM_SPEEDUP": "20"}) as system:
        system.wait_ready()
        system.wait_for(lambda: position(system), 20, "the rover's telemetry in the world model")
        url = project_broker_url(PROJECT, tmp_path / "run")
        assert url is not None
        operator = Operator(url)
        try:
            system.wait_for(operator.subscribed.is_set, 10,
                            "the operator's subscription")

            system.publish("mrss/ui/drive", {"goal": "g1", "lat": SITE[0], "lon": SITE[1]})
            system.wait_for(lambda: [s for s in system.statuses("rover1", "succeeded")
                                     if s.goal == "g1"], 60, "the legal drive")
            assert verdict(system, "g1") == {"action": "drive(rover1,g1,39.7705,44.8)",
                                             "legal": True, "rule": "", "detail": "",
                                             "geometry": None}
            here = position(system)
            assert here is not None and distance_m(*here, *SITE) < 5.0, system.log()

            system.wait_for(lambda: (system.world("rover1") or {}).get("attributes", {})
                            .get("speed") == 0.0, 10, "the world model to see the rover stopped")
            system.publish("mrss/ui/science", {"goal": "g2", "what": "sample"})
            sampled = system.wait_for(lambda: [s for s in system.statuses("rover1", "succeeded")
                                               if s.goal == "g2"], 60, "the sample")[0]
            assert sampled.progress["taken"] == "sample"
            assert str(sampled.progress["reading"]).endswith("in slot 1"), sampled.progress

            system.publish("mrss/ui/drive", {"goal": "g3", "lat": BEYOND_MARSH[0],
                                             "lon": BEYOND_MARSH[1]})
            refused = system.wait_for(lambda: verdict(system, "g3"), 30, "the verdict on g3")
            assert refused is not None and refused["legal"] is False, refused
            assert refused["rule"] == "no_go_path"
            assert "'salt_marsh'" in str(refused["detail"])
            system.wait_for(lambda: "g3: drive(rover1,g3,39.7725,44.801) refused by rule "
                            "no_go_path" in system.log(40000), 10, "the refusal in the log")
            assert not [s for s in system.statuses("rover1") if s.goal == "g3"]
            after = position(system)
            assert after is not None and distance_m(*after, *SITE) < 5.0

            told = system.wait_for(lambda: operator.verdict("g3"), 10, "the verdict on MQTT")
            assert told is not None and (told["legal"], told["rule"]) == (False, "no_go_path")
            assert "'salt_marsh'" in told["detail"]
            assert told["action"] == "drive(rover1,g3,39.7725,44.801)"
            assert operator.verdict("g1") == {"goal": "g1", "legal": True, "rule": "",
                                              "detail": "",
                                              "action": "drive(rover1,g1,39.7705,44.8)"}
            assert len(operator.verdicts("g1")) == 1, operator.received

            # crew telemetry from a suit: she stands on the next drive's path
            system.publish("mrss/ui/crew", {"id": "eva2", "lat": 39.77125, "lon": 44.79975})
            system.wait_for(lambda: (system.world("eva2") or {}).get("kind") == "crew", 10,
                            "the crew member in the world model")
            system.publish("mrss/ui/crew", {"id": "habitat", "lat": 39.0, "lon": 44.0})
            system.publish("mrss/ui/drive", {"goal": "g5", "lat": 39.772, "lon": 44.7995})
            close = system.wait_for(lambda: operator.verdict("g5"), 30, "the verdict on g5")
            assert close is not None and close["rule"] == "crew_safety", close
            assert "'eva2'" in close["detail"]
            assert not [s for s in system.statuses("rover1") if s.goal == "g5"]
            habitat = system.world("habitat")
            assert habitat is not None and habitat["kind"] == "base"     # not overwritten
        finally:
            operator.close()
