"""Publish one JSON message on an MQTT broker as an outside client (operators, tools, tests).

The message goes out with QoS 1 and the call returns once the broker acknowledged it;
a broker that cannot be reached or does not acknowledge within `timeout` raises
MrssError naming the topic (a malformed URL: ConfigError).
"""

from __future__ import annotations

import json
import os
from collections.abc import Mapping
from typing import Any

from mrss.errors import MrssError
from mrss.links.mqtt_url import BrokerAddress, new_client, parse_broker_url


def publish_json(broker_url: str, topic: str, payload: Mapping[str, Any] | list[Any], *,
                 client_id: str = "", timeout: float = 5.0) -> None:
    """Publish `payload` as JSON on `topic` of `broker_url` and wait for the broker's ack."""
    address = parse_broker_url(broker_url)
    client = new_client(client_id or f"mrss-publish-{os.getpid()}", address)
    start_client(client, address, broker_url, topic)
    try:
        info = client.publish(topic, json.dumps(payload), qos=1)
        info.wait_for_publish(timeout)
        if not info.is_published():
            raise MrssError(f"{topic}: not acknowledged by the broker {broker_url} "
                            f"within {timeout:g} s")
    finally:
        client.disconnect()
        client.loop_stop()


def start_client(client: Any, address: BrokerAddress, broker_url: str, topic: str) -> None:
    """Connect `client` and start its network loop; MrssError naming `topic` if the
    broker cannot be reached."""
    try:
        client.connect(address.host, address.port, keepalive=10)
    except OSError as exc:
        raise MrssError(f"{topic}: cannot reach the broker {broker_url}: {exc}") from None
    client.loop_start()
