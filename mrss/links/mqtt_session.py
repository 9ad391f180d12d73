"""One MQTT connection per broker and login for all the robot links of a process.

A link to an MQTT robot does not own a connection. Links that reach the same broker
with the same login (the same `BrokerAddress`) and keep-alive share one `MqttSession`:
one paho client, one TCP or TLS connection and one network thread, however many robots
there are (a fleet of 100 UGVs had 50 paho threads and 50 connections in the RCL). A
robot with its own credentials (docs/robots.md) has a session of its own, so the broker
still knows each robot's controller by its login.

The rules of a shared session:

* It connects when its first link attaches and disconnects when its last one detaches;
  paho reconnects it with a growing delay meanwhile.
* It subscribes each link's topics on every connect (a link attached while connected
  gets its subscriptions at once) and unsubscribes a detached link's topics that no
  other link uses.
* A message goes to the links subscribed to its exact topic, and only to them.
* Every link hears every change of the connection (connected, lost, cannot connect):
  they share it, so they go down and come back together.
* What one link does wrong in a callback is logged; the other links never see it.
"""

from __future__ import annotations

import itertools
import logging
import os
import threading
from collections.abc import Sequence
from typing import Any, Protocol

from paho.mqtt import client as mqtt

from mrss.links.mqtt_url import BrokerAddress, disable_nagle, new_client

log = logging.getLogger("mrss.links.mqtt")

RECONNECT_MIN_S = 1
RECONNECT_MAX_S = 10


class SessionMember(Protocol):
    """What a session needs of a link (all called on the session's network thread,
    except `session_connected` for a link that attaches to a connected session)."""

    def session_topics(self) -> Sequence[str]:
        """The topics this link subscribes (QoS 1)."""

    def session_connected(self) -> None:
        """The connection to the broker stands (after subscribing the topics)."""

    def session_down(self, reason: str) -> None:
        """The connection was lost, refused or could not be made, with the reason."""

    def session_message(self, topic: str, payload: bytes) -> None:
        """A message on one of this link's topics."""


_Key = tuple[BrokerAddress, int]
_sessions: dict[_Key, MqttSession] = {}
_sessions_lock = threading.Lock()
_numbers = itertools.count(1)


class MqttSession:
    """A shared connection to one broker (module docstring); get one with `attach`."""

    @classmethod
    def attach(cls, address: BrokerAddress, keepalive: int, member: SessionMember
               ) -> MqttSession:
        """The process's session for `address` and `keepalive` (made and connected for
        the first link) with `member` attached."""
        with _sessions_lock:
            session = _sessions.get((address, keepalive))
            if session is None:
                session = cls(address, keepalive)
                _sessions[(address, keepalive)] = session
            session._add(member)
        return session

    def __init__(self, address: BrokerAddress, keepalive: int) -> None:
        self.address = address
        self.keepalive = keepalive
        self._lock = threading.Lock()
        self._members: list[SessionMember] = []
        self._by_topic: dict[str, list[SessionMember]] = {}
        self._connected = False
        self._started = False
        client_id = f"mrss-links-{os.getpid():x}-{next(_numbers)}"
        self.client = new_client(client_id, address)
        self.client.on_connect = self._on_connect
        self.client.on_disconnect = self._on_disconnect
        self.client.on_connect_fail = self._on_connect_fail
        self.client.on_message = self._on_message
        self.client.reconnect_delay_set(min_delay=RECONNECT_MIN_S, max_delay=RECONNECT_MAX_S)

    @property
    def connected(self) -> bool:
        return self._connected

    @property
    def members(self) -> int:
        """How many links use this session."""
        with self._lock:
            return len(self._members)

    def publish(self, topic: str, payload: bytes, qos: int) -> None:
        self.client.publish(topic, payload, qos=qos)

    # -- members ---------------------------------------------------------------------------
    def _add(self, member: SessionMember) -> None:
        # Caller holds the registry lock.
        topics = list(member.session_topics())
        with self._lock:
            self._members.append(member)
            for topic in topics:
                self._by_topic.setdefault(topic, []).append(member)
            connected = self._connected
            start, self._started = not self._started, True
        if start:
            self.client.connect_async(self.address.host, self.address.port,
                                      keepalive=self.keepalive)
            self.client.loop_start()
        elif connected:
            for topic in topics:
                self.client.subscribe(topic, qos=1)
            self._tell(member, "session_connected")

    def detach(self, member: SessionMember) -> None:
        """`member` leaves; the last one to leave disconnects the session."""
        with _sessions_lock:
            with self._lock:
                if member not in self._members:
                    return
                self._members.remove(member)
                unused = []
                for topic in member.session_topics():
                    users = self._by_topic.get(topic, [])
                    if member in users:
                        users.remove(member)
                    if not users:
                        self._by_topic.pop(topic, None)
                        unused.append(topic)
                last = not self._members
            if last:
                del _sessions[(self.address, self.keepalive)]
        if last:
            self.client.disconnect()
            self.client.loop_stop()
        elif unused and self._connected:
            self.client.unsubscribe(unused)

    def _snapshot(self) -> list[SessionMember]:
        with self._lock:
            return list(self._members)

    def _tell(self, member: SessionMember, what: str, *args: Any, **kwargs: Any) -> None:
        try:
            getattr(member, what)(*args, **kwargs)
        except Exception:  # one link's bug must not reach the others
            log.exception("MQTT session %s:%d: a link failed in %s", self.address.host,
                          self.address.port, what)

    # -- paho callbacks (the session's network thread) -------------------------------------
    def _on_connect(self, client: mqtt.Client, userdata: Any, flags: Any,
                    reason_code: Any, properties: Any) -> None:
        if reason_code.is_failure:
            for member in self._snapshot():
                self._tell(member, "session_down",
                           f"broker refused the connection: {reason_code}")
            return
        disable_nagle(client)
        with self._lock:
            self._connected = True
            topics = list(self._by_topic)
        if topics:
            client.subscribe([(topic, 1) for topic in topics])
        log.info("connected to broker %s:%d for %d link(s)", self.address.host,
                 self.address.port, len(self._snapshot()))
        for member in self._snapshot():
            self._tell(member, "session_connected")

    def _on_connect_fail(self, client: mqtt.Client, userdata: Any) -> None:
        tls = " (TLS: is ca_certs the broker's CA?)" if self.address.tls else ""
        reason = f"cannot connect to {self.address.host}:{self.address.port}{tls}"
        for member in self._snapshot():
            self._tell(member, "session_down", reason)

    def _on_disconnect(self, client: mqtt.Client, userdata: Any, flags: Any,
                       reason_code: Any, properties: Any) -> None:
        with self._lock:
            was_connected, self._connected = self._connected, False
        if not was_connected:
            return  # a connection that never stood: its refusal or failure said why
        for member in self._snapshot():
            self._tell(member, "session_down", f"broker connection lost: {reason_code}")

    def _on_message(self, client: mqtt.Client, userdata: Any, message: Any) -> None:
        topic = str(message.topic)
        with self._lock:
            members = list(self._by_topic.get(topic, ()))
        payload = bytes(message.payload)
        for member in members:
            self._tell(member, "session_message", topic, payload)
