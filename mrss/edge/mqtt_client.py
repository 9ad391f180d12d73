"""An MQTT client for adapters and links: paho-mqtt 2.x, reconnecting, re-subscribing.

    settings = MqttSettings.from_config({"url": "mqtts://broker:8883", "username": "u"})
    client = MqttClient(settings, client_id="events")
    client.subscribe("ui/area/#", on_area)       # on_area(topic: str, payload: bytes)
    client.start()                               # connects in the background
    client.publish("robots/ugv1/cmd", b"{...}")
    client.stop()

The network loop runs on paho's thread. It reconnects with exponential backoff between
`reconnect_min` and `reconnect_max` seconds and subscribes again to every filter after
each (re)connect, so a broker restart loses no subscriptions. A callback that raises is
logged and counted (`callback_errors`), never allowed to kill the network thread.

At-least-once receiving (the events manager): a stable `client_id` with
`clean_session=False` keeps the broker's session, so QoS 1 messages published while
the client is away are queued for it; with `manual_ack=True` a QoS 1 message is
acknowledged (PUBACK) only when the application calls `ack(delivery)`, so a message
in hand when the process dies is delivered again (`Delivery.redelivered`, the MQTT
DUP flag). `subscribe_deliveries` hands over the whole `Delivery`; plain `subscribe`
callbacks are acknowledged as soon as they return.
"""

from __future__ import annotations

import logging
import os
import ssl
import threading
from collections.abc import Callable, Mapping
from dataclasses import dataclass, replace
from typing import Any
from urllib.parse import unquote, urlsplit

import paho.mqtt.client as mqtt
from paho.mqtt.enums import CallbackAPIVersion

from mrss.errors import ConfigError

MessageCallback = Callable[[str, bytes], None]


@dataclass(frozen=True)
class Delivery:
    """One received MQTT message, with what is needed to acknowledge it."""

    topic: str
    payload: bytes
    qos: int
    redelivered: bool
    mid: int


DeliveryCallback = Callable[[Delivery], None]
DEFAULT_PORTS = {"mqtt": 1883, "tcp": 1883, "mqtts": 8883, "ssl": 8883}


@dataclass(frozen=True)
class MqttSettings:
    """Where a broker is and how to log in: the `[broker]` table of project.toml."""

    host: str = "127.0.0.1"
    port: int = 1883
    tls: bool = False
    username: str | None = None
    password: str | None = None
    ca_certs: str | None = None
    certfile: str | None = None
    keyfile: str | None = None
    tls_insecure: bool = False
    keepalive: int = 30
    reconnect_min: float = 0.2
    reconnect_max: float = 30.0

    @property
    def url(self) -> str:
        """The broker URL, without credentials."""
        return f"{'mqtts' if self.tls else 'mqtt'}://{self.host}:{self.port}"

    @classmethod
    def from_url(cls, url: str) -> MqttSettings:
        """Parse `mqtt://[user[:password]@]host[:port]` or `mqtts://...` (TLS)."""
        parts = urlsplit(url)
        scheme = parts.scheme.lower()
        if scheme not in DEFAULT_PORTS:
            raise ConfigError(f"broker URL {url!r} must start with mqtt:// or mqtts://",
                              key="broker.url")
        if not parts.hostname:
            raise ConfigError(f"broker URL {url!r} has no host", key="broker.url")
        if parts.path not in ("", "/") or parts.query or parts.fragment:
            raise ConfigError(f"broker URL {url!r} must not have a path or query",
                              key="broker.url")
        try:
            port = parts.port or DEFAULT_PORTS[scheme]
        except ValueError:
            raise ConfigError(f"broker URL {url!r} has a bad port", key="broker.url") from None
        return cls(
            host=parts.hostname, port=port, tls=scheme in ("mqtts", "ssl"),
            username=unquote(parts.username) if parts.username else None,
            password=unquote(parts.password) if parts.password else None,
        )

    @classmethod
    def from_config(cls, table: Mapping[str, Any], *, url: str | None = None) -> MqttSettings:
        """Settings from a `[broker]` table; `url` (e.g. the embedded broker's) wins if given.

        The password may come from the environment: `password_env = "VAR"`.
        """
        target = url or table.get("url")
        if not target or not isinstance(target, str):
            raise ConfigError("no broker URL", key="broker.url")
        settings = cls.from_url(target)
        changes: dict[str, Any] = {}
        for key, kind in (("username", str), ("password", str), ("ca_certs", str),
                          ("certfile", str), ("keyfile", str), ("tls_insecure", bool),
                          ("keepalive", int), ("reconnect_min", (int, float)),
                          ("reconnect_max", (int, float))):
            if key in table:
                value = table[key]
                if isinstance(value, bool) and kind is not bool or not isinstance(value, kind):
                    raise ConfigError(f"must be {getattr(kind, '__name__', 'a number')}",
                                      key=f"broker.{key}")
                changes[key] = value
        env = table.get("password_env")
        if env:
            if not isinstance(env, str) or env not in os.environ:
                raise ConfigError(f"environment variable {env!r} is not set",
                                  key="broker.password_env")
            changes["password"] = os.environ[env]
        if table.get("tls") is True or changes.get("ca_certs"):
            changes["tls"] = True
        settings = replace(settings, **changes)
        if settings.reconnect_min <= 0 or settings.reconnect_max < settings.reconnect_min:
            raise ConfigError("need 0 < reconnect_min <= reconnect_max", key="broker.reconnect_min")
        return settings


class MqttClient:
    """A paho-mqtt 2.x client that keeps its subscriptions across reconnects."""

    def __init__(self, settings: MqttSettings, *, client_id: str = "",
                 logger: logging.Logger | None = None, clean_session: bool = True,
                 manual_ack: bool = False) -> None:
        self.settings = settings
        self.log = logger or logging.getLogger("mrss.mqtt")
        self._subs: dict[str, int] = {}
        self.manual_ack = manual_ack
        self._lock = threading.Lock()
        self._connected = threading.Event()
        self._acked: set[str] = set()
        self._pending_mids: dict[int, str] = {}
        self._acks = threading.Condition(self._lock)
        self.connects = 0
        self.callback_errors = 0
        if not clean_session and not client_id:
            raise ConfigError("a persistent MQTT session needs a client id",
                              key="events.client_id")
        self._client = mqtt.Client(CallbackAPIVersion.VERSION2, client_id=client_id,
                                   protocol=mqtt.MQTTv311, clean_session=clean_session,
                                   manual_ack=manual_ack)
        self._client.reconnect_delay_set(settings.reconnect_min,  # type: ignore[arg-type]
                                         settings.reconnect_max)  # type: ignore[arg-type]
        if settings.username is not None:
            self._client.username_pw_set(settings.username, settings.password)
        if settings.tls:
            self._client.tls_set(ca_certs=settings.ca_certs, certfile=settings.certfile,
                                 keyfile=settings.keyfile, cert_reqs=ssl.CERT_REQUIRED)
            self._client.tls_insecure_set(settings.tls_insecure)
        self._client.on_connect = self._on_connect
        self._client.on_disconnect = self._on_disconnect
        self._client.on_message = self._on_unrouted
        self._client.on_subscribe = self._on_subscribe
        self._started = False
        self._stopping = False

    @property
    def connected(self) -> bool:
        """True while a session with the broker is up."""
        return self._connected.is_set()

    def wait_connected(self, timeout: float) -> bool:
        """Block until connected or `timeout` seconds passed; True if connected."""
        return self._connected.wait(timeout)

    def start(self) -> None:
        """Connect in the background; paho's thread retries until the broker answers."""
        if self._started:
            return
        self._started = True
        self._stopping = False
        self._client.connect_async(self.settings.host, self.settings.port,
                                   keepalive=self.settings.keepalive)
        self._client.loop_start()

    def stop(self) -> None:
        """Disconnect and stop the network thread."""
        if not self._started:
            return
        self._started = False
        self._stopping = True
        self._client.disconnect()
        self._client.loop_stop()
        self._connected.clear()

    def subscribe(self, topic_filter: str, callback: MessageCallback, qos: int = 1) -> None:
        """Deliver messages matching `topic_filter` to `callback(topic, payload)`."""
        def plain(delivery: Delivery) -> None:
            try:
                callback(delivery.topic, delivery.payload)
            finally:
                self.ack(delivery)
        self.subscribe_deliveries(topic_filter, plain, qos)

    def subscribe_deliveries(self, topic_filter: str, callback: DeliveryCallback,
                             qos: int = 1) -> None:
        """Deliver messages matching `topic_filter` to `callback(delivery)`; with
        `manual_ack`, the callback's owner must `ack(delivery)` each one."""
        with self._lock:
            self._subs[topic_filter] = qos
        self._client.message_callback_add(topic_filter, self._guarded(topic_filter, callback))
        if self.connected:
            self._send_subscribe(self._client, topic_filter, qos)

    def ack(self, delivery: Delivery) -> None:
        """Acknowledge a delivery to the broker (only needed with `manual_ack`).

        When the connection is down the acknowledgement is lost and the broker delivers
        the message again after the reconnect: receivers de-duplicate.
        """
        if self.manual_ack and delivery.qos > 0:
            self._client.ack(delivery.mid, delivery.qos)

    def wait_subscribed(self, timeout: float) -> bool:
        """Block until the broker acknowledged every subscription of this session."""
        with self._acks:
            return self._acks.wait_for(
                lambda: self._connected.is_set() and set(self._subs) <= self._acked, timeout)

    def _send_subscribe(self, client: mqtt.Client, topic_filter: str, qos: int) -> None:
        with self._lock:
            self._acked.discard(topic_filter)
            result, mid = client.subscribe(topic_filter, qos=qos)
            if result == mqtt.MQTT_ERR_SUCCESS and mid is not None:
                self._pending_mids[mid] = topic_filter

    def _on_subscribe(self, _client: Any, _userdata: Any, mid: int, reason_codes: Any,
                      _properties: Any) -> None:
        with self._acks:
            topic_filter = self._pending_mids.pop(mid, None)
            if topic_filter is None:
                return
            if any(rc.is_failure for rc in reason_codes):
                self.log.warning("broker refused subscription %r: %s", topic_filter,
                                 reason_codes)
                return
            self._acked.add(topic_filter)
            self._acks.notify_all()

    def unsubscribe(self, topic_filter: str) -> None:
        """Stop delivering `topic_filter`."""
        with self._lock:
            self._subs.pop(topic_filter, None)
        self._client.message_callback_remove(topic_filter)
        if self.connected:
            self._client.unsubscribe(topic_filter)

    def publish(self, topic: str, payload: bytes | str, qos: int = 1,
                retain: bool = False) -> bool:
        """Queue a message; False when paho refuses it (e.g. queue full)."""
        info = self._client.publish(topic, payload, qos=qos, retain=retain)
        return bool(info.rc == mqtt.MQTT_ERR_SUCCESS)

    def set_will(self, topic: str, payload: bytes | str, qos: int = 1,
                 retain: bool = False) -> None:
        """Last will, sent by the broker if this client vanishes (call before start)."""
        self._client.will_set(topic, payload, qos=qos, retain=retain)

    def _guarded(self, topic_filter: str, callback: DeliveryCallback) -> Callable[..., None]:
        def deliver(_client: Any, _userdata: Any, message: mqtt.MQTTMessage) -> None:
            try:
                callback(Delivery(message.topic, bytes(message.payload), int(message.qos),
                                  bool(message.dup), int(message.mid)))
            except Exception:
                self.callback_errors += 1
                self.log.exception("callback for %r failed on topic %r", topic_filter,
                                   getattr(message, "topic", "?"))
        return deliver

    def _on_unrouted(self, _client: Any, _userdata: Any, message: mqtt.MQTTMessage) -> None:
        self.log.debug("message on %r matches no callback", message.topic)

    def _on_connect(self, client: mqtt.Client, _userdata: Any, _flags: Any,
                    reason_code: Any, _properties: Any) -> None:
        if reason_code.is_failure:
            self.log.warning("broker %s refused the connection: %s", self.settings.url,
                             reason_code)
            return
        self.connects += 1
        with self._lock:
            subs = list(self._subs.items())
            self._acked.clear()
            self._pending_mids.clear()
        for topic, qos in subs:
            self._send_subscribe(client, topic, qos)
        self.log.info("connected to %s (%d subscriptions)", self.settings.url, len(subs))
        with self._acks:
            self._connected.set()
            self._acks.notify_all()

    def _on_disconnect(self, _client: Any, _userdata: Any, _flags: Any, reason_code: Any,
                       _properties: Any) -> None:
        if self._connected.is_set() and not self._stopping:
            self.log.warning("disconnected from %s: %s", self.settings.url, reason_code)
        self._connected.clear()
