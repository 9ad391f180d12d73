"""Broker resolution: a configured URL wins; without one the embedded amqtt serves on loopback."""

from __future__ import annotations

import asyncio
import socket
import threading

import pytest

from mrss.actors.broker.service import BrokerError, EmbeddedBroker, resolve_broker, with_broker_url
from mrss.edge.mqtt_client import Delivery, MqttClient, MqttSettings
from mrss.errors import ConfigError
from mrss.testing import free_port, wait_until


def test_configured_url_means_nothing_embedded() -> None:
    assert resolve_broker({"broker": {"url": "mqtt://10.1.2.3:1884"}}) == (
        "mqtt://10.1.2.3:1884", False)
    config, embedded = with_broker_url({"broker": {"url": "mqtts://b:8883"}, "x": {"y": 1}})
    assert not embedded and config["broker"]["url"] == "mqtts://b:8883"


def test_no_url_picks_a_free_loopback_port_and_fills_in_the_config() -> None:
    url, embedded = resolve_broker({})
    assert embedded and url.startswith("mqtt://127.0.0.1:")
    port = int(url.rsplit(":", 1)[1])
    with socket.socket() as s:
        s.bind(("127.0.0.1", port))  # nothing listens there yet
    original = {"broker": {"embedded": {"port": 18999}}, "events": {}}
    config, embedded = with_broker_url(original)
    assert embedded and config["broker"]["url"] == "mqtt://127.0.0.1:18999"
    assert "url" not in original["broker"]  # the caller's config is not modified


@pytest.mark.parametrize("config", [
    {"broker": {"url": "http://x"}}, {"broker": "mqtt://x"},
    {"broker": {"embedded": {"port": 70000}}}, {"broker": {"embedded": {"host": 5}}},
])
def test_bad_broker_config_is_a_config_error(config: dict[str, object]) -> None:
    with pytest.raises(ConfigError):
        resolve_broker(config)


def test_embedded_broker_component_serves_clients_and_stops() -> None:
    config, embedded = with_broker_url({})
    assert embedded
    broker = EmbeddedBroker()
    got: list[bytes] = []
    client = MqttClient(MqttSettings.from_config(config["broker"]))
    try:
        broker.serve_at(config["broker"]["url"])
        assert broker.running
        client.subscribe("emb/t", lambda topic, payload: got.append(payload))
        client.start()
        assert client.wait_subscribed(10)
        client.publish("emb/t", b"via embedded")
        wait_until(lambda: got == [b"via embedded"], timeout=10, message="delivery")
    finally:
        client.stop()
        broker.stop()
    assert not broker.running
    with socket.socket() as s:  # the port is free again
        s.bind(("127.0.0.1", int(config["broker"]["url"].rsplit(":", 1)[1])))


def test_embedded_broker_on_a_taken_port_fails_clearly() -> None:
    port = free_port()
    with socket.socket() as blocker:
        blocker.bind(("127.0.0.1", port))
        blocker.listen()
        broker = EmbeddedBroker()
        try:
            with pytest.raises(BrokerError, match=str(port)):
                broker.serve_at(f"mqtt://127.0.0.1:{port}", timeout=10)
        finally:
            broker.stop()
    with pytest.raises(ConfigError):
        EmbeddedBroker().serve_at("mqtts://127.0.0.1:1")


def test_stop_after_the_broker_loop_closed_but_before_its_thread_ended_is_harmless() -> None:
    """The window a failed start leaves (seen in CI: stop() raised 'Event loop is
    closed'): the loop is closed while the thread still runs its last lines."""
    broker = EmbeddedBroker()
    loop = asyncio.new_event_loop()
    broker._loop, broker._stop = loop, asyncio.Event()
    loop.close()
    # the thread's last lines: alive when stop() looks, over within a second
    broker._thread = threading.Thread(target=threading.Event().wait, args=(1.0,), daemon=True)
    broker._thread.start()
    assert broker.running
    broker.stop()  # joins the thread
    assert not broker.running


def test_embedded_broker_keeps_a_persistent_session_for_a_client_that_is_away() -> None:
    """The events manager's goals published while it restarts wait for it (QoS 1)."""
    broker = EmbeddedBroker()
    broker.serve_at(f"mqtt://127.0.0.1:{free_port()}")
    settings = MqttSettings.from_url(broker.url)
    sender = MqttClient(settings, client_id="operator")
    watcher = MqttClient(settings, client_id="watcher")  # sees when the broker has it
    got: list[bytes] = []
    watched: list[bytes] = []
    watcher.subscribe("ui/#", lambda _topic, payload: watched.append(payload))

    def session() -> MqttClient:
        client = MqttClient(settings, client_id="mrss-test-events", clean_session=False,
                            manual_ack=True)

        def take(delivery: Delivery) -> None:
            got.append(delivery.payload)
            client.ack(delivery)
        client.subscribe_deliveries("ui/#", take)
        client.start()
        assert client.wait_subscribed(20)
        return client

    try:
        first = session()
        watcher.start()
        assert watcher.wait_subscribed(20)
        sender.start()
        assert sender.wait_connected(20)
        sender.publish("ui/area", b"one", qos=1)
        wait_until(lambda: got == [b"one"], timeout=20, message="delivered while connected")
        first.stop()  # away (e.g. restarting)
        # the broker has read the DISCONNECT by the time it answers a connection opened
        # after it: "two" is then routed to the stored session, not the closing socket
        probe = MqttClient(settings, client_id="probe")
        probe.start()
        assert probe.wait_connected(20)
        probe.stop()
        sender.publish("ui/area", b"two", qos=1)
        wait_until(lambda: b"two" in watched, timeout=20, message="the broker has it")
        second = session()  # the next incarnation: same client id, same session
        try:
            wait_until(lambda: got == [b"one", b"two"], timeout=20,
                       message="the message published while away")
        finally:
            second.stop()
    finally:
        sender.stop()
        watcher.stop()
        broker.stop()
