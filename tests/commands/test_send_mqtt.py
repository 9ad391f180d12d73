"""`mrss send mqtt TOPIC JSON`: an outside MQTT event, through the project's broker."""

from __future__ import annotations

import json
import threading
from collections.abc import Iterator
from pathlib import Path
from typing import Any

import pytest

from mrss.links.mqtt_url import new_client, parse_broker_url
from mrss.testing import BrokerInfo, wait_until
from tests.commands.cli_bus import mrss


@pytest.fixture()
def received(mqtt_broker: BrokerInfo) -> Iterator[list[tuple[str, Any]]]:
    """Messages on mrss/test/#, as (topic, decoded JSON)."""
    got: list[tuple[str, Any]] = []
    subscribed = threading.Event()
    address = parse_broker_url(mqtt_broker.url)
    client = new_client("send-mqtt-watcher", address)
    client.on_connect = lambda c, *a: c.subscribe("mrss/test/#", qos=1)
    client.on_subscribe = lambda *a: subscribed.set()
    client.on_message = lambda c, u, m: got.append((m.topic, json.loads(m.payload)))
    client.connect(address.host, address.port)
    client.loop_start()
    try:
        wait_until(subscribed.is_set, 10, message="subscribed")
        yield got
    finally:
        client.disconnect()
        client.loop_stop()


def test_json_goes_to_the_broker_of_the_run_dir(tmp_path: Path, mqtt_broker: BrokerInfo,
                                                received: list[tuple[str, Any]]) -> None:
    (tmp_path / "broker.url").write_text(mqtt_broker.url + "\n", encoding="utf-8")
    out = mrss("send", "--run-dir", str(tmp_path), "mqtt", "mrss/test/area",
               '{"goal": "a1", "priority": 2}')
    assert out.returncode == 0, out.stderr
    assert f"published on mrss/test/area via {mqtt_broker.url}" in out.stdout
    wait_until(lambda: received, 10, message="the message at the subscriber")
    assert received == [("mrss/test/area", {"goal": "a1", "priority": 2})]


def test_bad_json_topic_or_no_broker_exit_2_and_send_nothing(tmp_path: Path) -> None:
    out = mrss("send", "--run-dir", str(tmp_path), "mqtt", "mrss/test/a", "{goal: a1}")
    assert out.returncode == 2 and "JSON is not valid" in out.stderr
    out = mrss("send", "--run-dir", str(tmp_path), "mqtt", "mrss/test/#", "{}")
    assert out.returncode == 2 and "no wildcards" in out.stderr
    out = mrss("send", "--run-dir", str(tmp_path), "mqtt", "mrss/test/a", "{}")
    assert out.returncode == 2 and "no broker: give --broker URL" in out.stderr
