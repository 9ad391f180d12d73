"""`mrss.api.request_json` on a real broker: an event is sent again, with its id, until
an answer naming that id arrives; nobody answering is a clear error, not a hang."""

from __future__ import annotations

import json
import threading
from collections.abc import Iterator
from typing import Any

import pytest

from mrss.api import MrssError, request_json
from mrss.links.mqtt_url import new_client, parse_broker_url
from mrss.testing import BrokerInfo, wait_until


class Responder:
    """A stand-in for the events manager that ignores the first `drop` deliveries of
    each event (as if a broker had lost them) and answers the rest on `<topic>/reply`."""

    def __init__(self, url: str, drop: int) -> None:
        self.drop = drop
        self.seen: list[dict[str, Any]] = []
        self._subscribed = threading.Event()
        address = parse_broker_url(url)
        self.client = new_client("request-responder", address)
        self.client.on_connect = lambda c, *a: c.subscribe("ops/area", qos=1)
        self.client.on_subscribe = lambda *a: self._subscribed.set()
        self.client.on_message = self._on_message
        self.client.connect(address.host, address.port)
        self.client.loop_start()
        wait_until(self._subscribed.is_set, 10, message="the responder subscribed")

    def _on_message(self, client: Any, _userdata: Any, msg: Any) -> None:
        event = json.loads(msg.payload)
        self.seen.append(event)
        if len(self.seen) > self.drop:
            status = "accepted" if len(self.seen) == self.drop + 1 else "duplicate"
            client.publish("ops/area/reply", json.dumps(
                {"status": status, "id": event["id"], "goal": event.get("goal")}), qos=1)

    def close(self) -> None:
        self.client.disconnect()
        self.client.loop_stop()


@pytest.fixture()
def responder(mqtt_broker: BrokerInfo, request: pytest.FixtureRequest) -> Iterator[Responder]:
    r = Responder(mqtt_broker.url, drop=request.param)
    try:
        yield r
    finally:
        r.close()


@pytest.mark.parametrize("responder", [2], indirect=True)
def test_an_unanswered_event_is_sent_again_with_its_id_until_answered(
        mqtt_broker: BrokerInfo, responder: Responder) -> None:
    answer = request_json(mqtt_broker.url, "ops/area", {"goal": "a1"}, within=0.3,
                          patience=30)
    assert answer["status"] == "accepted" and answer["goal"] == "a1"
    ids = {e["id"] for e in responder.seen}
    assert len(responder.seen) >= 3 and len(ids) == 1  # the same event, again and again


@pytest.mark.parametrize("responder", [1_000_000], indirect=True)
def test_nobody_answering_is_an_error_naming_the_reply_topic(
        mqtt_broker: BrokerInfo, responder: Responder) -> None:
    with pytest.raises(MrssError, match="no answer on ops/area/reply for event op-9"):
        request_json(mqtt_broker.url, "ops/area", {"goal": "a1", "id": "op-9"},
                     within=0.2, patience=1.0)
    assert {e["id"] for e in responder.seen} == {"op-9"} and len(responder.seen) >= 2


def test_an_unreachable_broker_is_an_error() -> None:
    with pytest.raises(MrssError, match="cannot reach the broker"):
        request_json("mqtt://127.0.0.1:1", "ops/area", {"goal": "a1"}, patience=1.0)
