"""The test brokers accept a real MQTT client and deliver a message."""

from __future__ import annotations

import threading

import paho.mqtt.client as mqtt
import pytest

from mrss.testing import BrokerInfo, wait_until
from tests import mosquitto


def _roundtrip(info: BrokerInfo) -> bytes:
    got: list[bytes] = []
    subscribed = threading.Event()
    client = mqtt.Client(mqtt.CallbackAPIVersion.VERSION2, client_id="fixture-test")
    client.on_message = lambda c, u, m: got.append(m.payload)
    client.on_subscribe = lambda *a: subscribed.set()
    client.on_connect = lambda c, u, f, rc, p: c.subscribe("t/#", qos=1)
    client.connect(info.host, info.port)
    client.loop_start()
    try:
        wait_until(subscribed.is_set, timeout=10, message="subscription")
        client.publish("t/x", b"hello", qos=1)
        wait_until(lambda: got, timeout=10, message="message delivery")
        return got[0]
    finally:
        client.disconnect()  # first: a loop stopped first sits out its 1 s select
        client.loop_stop()


def test_private_broker_delivers(mqtt_broker: BrokerInfo) -> None:
    assert mqtt_broker.host == "127.0.0.1"
    if mosquitto.required():  # CI: the broker under every MQTT test is Mosquitto
        assert mqtt_broker.kind == "mosquitto"
    assert mqtt_broker.port != 1883
    assert _roundtrip(mqtt_broker) == b"hello"


def test_embedded_amqtt_broker_delivers(amqtt: BrokerInfo) -> None:
    assert amqtt.kind == "amqtt"
    assert _roundtrip(amqtt) == b"hello"


def test_missing_mosquitto_skips_or_fails_when_required(monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.delenv(mosquitto.REQUIRE_ENV, raising=False)
    with pytest.raises(pytest.skip.Exception, match="the TLS tests needs no-such-tool"):
        mosquitto.require_mosquitto("/usr/sbin/mosquitto", "the TLS tests", ("no-such-tool",))
    monkeypatch.setenv(mosquitto.REQUIRE_ENV, "1")
    with pytest.raises(pytest.fail.Exception, match="no-such-tool.*MRSS_REQUIRE_MOSQUITTO=1"):
        mosquitto.require_mosquitto("/usr/sbin/mosquitto", "the TLS tests", ("no-such-tool",))
    with pytest.raises(pytest.fail.Exception, match="the redelivery test needs mosquitto"):
        mosquitto.require_mosquitto(None, "the redelivery test")
    assert mosquitto.require_mosquitto("/usr/sbin/mosquitto", "it") == "/usr/sbin/mosquitto"
