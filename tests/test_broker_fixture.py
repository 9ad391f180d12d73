"""The test brokers accept a real MQTT client and deliver a message."""

from __future__ import annotations

import threading

import paho.mqtt.client as mqtt

from mrss.testing import BrokerInfo, wait_until


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
    assert mqtt_broker.port != 1883
    assert _roundtrip(mqtt_broker) == b"hello"


def test_embedded_amqtt_broker_delivers(amqtt: BrokerInfo) -> None:
    assert amqtt.kind == "amqtt"
    assert _roundtrip(amqtt) == b"hello"
