"""The MQTT helper connects, survives broker restarts with its subscriptions, and logs in."""

from __future__ import annotations

import threading
from collections.abc import Iterator
from contextlib import contextmanager

import pytest

from mrss.edge.mqtt_client import MqttClient, MqttSettings
from mrss.errors import ConfigError
from mrss.testing import BrokerInfo, wait_until

from .conftest import RestartableAmqtt, SecureBroker


@contextmanager
def running(settings: MqttSettings, client_id: str = "") -> Iterator[MqttClient]:
    client = MqttClient(settings, client_id=client_id)
    client.start()
    try:
        yield client
    finally:
        client.stop()


class Inbox:
    def __init__(self) -> None:
        self.items: list[tuple[str, bytes]] = []
        self.lock = threading.Lock()

    def __call__(self, topic: str, payload: bytes) -> None:
        with self.lock:
            self.items.append((topic, payload))


def test_url_parsing() -> None:
    s = MqttSettings.from_url("mqtt://broker.local:1884")
    assert (s.host, s.port, s.tls, s.username) == ("broker.local", 1884, False, None)
    s = MqttSettings.from_url("mqtts://u%40x:p%3Aw@10.0.0.2")
    assert (s.host, s.port, s.tls, s.username, s.password) == ("10.0.0.2", 8883, True, "u@x",
                                                               "p:w")
    assert MqttSettings.from_url("mqtt://h").port == 1883
    for bad in ("http://h:1", "mqtt://", "mqtt://h:99999", "mqtt://h:1/path", "h:1883"):
        with pytest.raises(ConfigError):
            MqttSettings.from_url(bad)


def test_config_table_adds_credentials_tls_and_env_password(
        monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setenv("MRSS_TEST_PW", "from-env")
    s = MqttSettings.from_config({"url": "mqtt://h:1", "username": "u", "password_env":
                                  "MRSS_TEST_PW", "ca_certs": "/ca.pem", "keepalive": 10})
    assert (s.username, s.password, s.tls, s.ca_certs, s.keepalive) == (
        "u", "from-env", True, "/ca.pem", 10)
    assert MqttSettings.from_config({}, url="mqtt://e:5").port == 5
    with pytest.raises(ConfigError, match="keepalive"):
        MqttSettings.from_config({"url": "mqtt://h", "keepalive": "10"})
    with pytest.raises(ConfigError, match="NOPE"):
        MqttSettings.from_config({"url": "mqtt://h", "password_env": "NOPE"})
    with pytest.raises(ConfigError, match="broker.url"):
        MqttSettings.from_config({})


def test_subscribe_and_receive_on_mosquitto(mqtt_broker: BrokerInfo) -> None:
    inbox = Inbox()
    settings = MqttSettings.from_url(mqtt_broker.url)
    with running(settings, "rx") as rx, running(settings, "tx") as tx:
        rx.subscribe("edge/test/+", inbox)
        assert rx.wait_subscribed(10)
        assert tx.wait_connected(10)
        tx.publish("edge/test/a", b"one")
        tx.publish("edge/other", b"ignored")
        tx.publish("edge/test/b", b"two")
        wait_until(lambda: len(inbox.items) >= 2, timeout=10, message="two messages")
        assert sorted(inbox.items) == [("edge/test/a", b"one"), ("edge/test/b", b"two")]


def test_a_raising_callback_is_counted_and_the_client_keeps_working(
        mqtt_broker: BrokerInfo) -> None:
    inbox = Inbox()

    def explode(topic: str, payload: bytes) -> None:
        raise RuntimeError("boom")

    settings = MqttSettings.from_url(mqtt_broker.url)
    with running(settings) as client:
        client.subscribe("edge/boom", explode)
        client.subscribe("edge/fine", inbox)
        assert client.wait_subscribed(10)
        client.publish("edge/boom", b"x")
        wait_until(lambda: client.callback_errors == 1, timeout=10, message="counted error")
        client.publish("edge/fine", b"y")
        wait_until(lambda: inbox.items == [("edge/fine", b"y")], timeout=10,
                   message="later delivery")


def test_reconnects_and_resubscribes_after_broker_restart(
        restartable_amqtt: RestartableAmqtt) -> None:
    inbox = Inbox()
    settings = MqttSettings.from_config({"url": restartable_amqtt.url, "reconnect_min": 0.1,
                                         "reconnect_max": 0.5})
    with running(settings, "survivor") as client:
        client.subscribe("edge/restart", inbox)
        assert client.wait_subscribed(20)
        restartable_amqtt.stop()
        wait_until(lambda: not client.connected, timeout=10, message="disconnect noticed")
        restartable_amqtt.start()
        wait_until(lambda: client.connects >= 2, timeout=20, message="reconnect")
        assert client.wait_subscribed(20)
        with running(settings, "sender") as sender:
            assert sender.wait_connected(20)
            sender.publish("edge/restart", b"after")
            wait_until(lambda: inbox.items == [("edge/restart", b"after")], timeout=20,
                       message="delivery after restart")


def test_starts_before_the_broker_exists_and_connects_when_it_appears(
        restartable_amqtt: RestartableAmqtt) -> None:
    restartable_amqtt.stop()
    settings = MqttSettings.from_config({"url": restartable_amqtt.url, "reconnect_min": 0.1,
                                         "reconnect_max": 0.3})
    with running(settings) as client:
        assert not client.wait_connected(0.3)
        restartable_amqtt.start()
        assert client.wait_connected(20)


def test_password_login_and_refusal(secure_mosquitto: SecureBroker) -> None:
    base = {"url": f"mqtt://127.0.0.1:{secure_mosquitto.port}", "username": "mrss",
            "reconnect_min": 0.2, "reconnect_max": 0.5}
    with running(MqttSettings.from_config({**base, "password": "s3cret"})) as good:
        assert good.wait_connected(10)
    with running(MqttSettings.from_config({**base, "password": "wrong"})) as bad:
        assert not bad.wait_connected(1.0)
        assert bad.connects == 0


def test_tls_with_ca_file_and_credentials_in_url(secure_mosquitto: SecureBroker) -> None:
    inbox = Inbox()
    settings = MqttSettings.from_config(
        {"url": f"mqtts://mrss:s3cret@127.0.0.1:{secure_mosquitto.tls_port}",
         "ca_certs": str(secure_mosquitto.ca_file)})
    assert settings.tls
    with running(settings) as client:
        client.subscribe("edge/tls", inbox)
        assert client.wait_subscribed(10)
        client.publish("edge/tls", b"secret")
        wait_until(lambda: inbox.items == [("edge/tls", b"secret")], timeout=10,
                   message="TLS round trip")
