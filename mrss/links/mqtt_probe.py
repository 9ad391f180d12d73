"""A plain MQTT client for tests and tools: publish, and record what arrives."""

from __future__ import annotations

import threading
from typing import Any

from paho.mqtt import client as mqtt
from paho.mqtt.enums import CallbackAPIVersion


class MqttProbe:
    """Connects at once, subscribes to `topics`, and keeps every message it receives."""

    def __init__(self, host: str, port: int, topics: list[str]) -> None:
        self.messages: list[tuple[str, bytes]] = []
        self._lock = threading.Lock()
        self.client = mqtt.Client(CallbackAPIVersion.VERSION2, client_id=f"probe-{id(self):x}")
        self.client.on_message = self._on_message
        self.client.connect(host, port, keepalive=10)
        for topic in topics:
            self.client.subscribe(topic, qos=1)
        self.client.loop_start()

    def _on_message(self, client: mqtt.Client, userdata: Any, message: Any) -> None:
        with self._lock:
            self.messages.append((str(message.topic), bytes(message.payload)))

    def received(self, topic: str) -> list[bytes]:
        """Payloads received on `topic`, oldest first."""
        with self._lock:
            return [payload for t, payload in self.messages if t == topic]

    def publish(self, topic: str, payload: bytes | str, retain: bool = False) -> None:
        """Publish with QoS 1 and wait until the broker has it."""
        self.client.publish(topic, payload, qos=1, retain=retain).wait_for_publish(timeout=5)

    def close(self) -> None:
        """Disconnect."""
        self.client.disconnect()
        self.client.loop_stop()
