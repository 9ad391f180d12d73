"""Send one JSON event to MRSS over MQTT and wait for its answer, as an operator's console.

The broker's acknowledgement (QoS 1) only says the broker has the message: a broker that
dies before delivering it loses it. The events manager answers every event on its reply
topic when the project sets `[events] reply_accepted = true` (default reply topic:
`<topic>/reply`), naming the event's `id`. `request_json` subscribes to that topic,
publishes the event with an `id` (one is added when the payload has none), and sends it
again, with the same id, whenever no answer came within `within` seconds, for at most
`patience` seconds. The events manager handles an id once and answers a repeat as a
`duplicate`, so sending again is safe. Returns the answer (a dict with `status`:
accepted, duplicate, rejected or failed, and `reason`); raises MrssError when the broker
cannot be reached or nobody answers in time.
"""

from __future__ import annotations

import json
import os
import threading
import time
import uuid
from collections.abc import Mapping
from typing import Any

from mrss.errors import MrssError
from mrss.links.mqtt_publish import start_client
from mrss.links.mqtt_url import new_client, parse_broker_url


def request_json(broker_url: str, topic: str, payload: Mapping[str, Any], *,
                 reply_topic: str = "", within: float = 5.0, patience: float = 30.0,
                 client_id: str = "") -> dict[str, Any]:
    """Publish `payload` on `topic` until an answer naming its id arrives; the answer."""
    event = dict(payload)
    event.setdefault("id", uuid.uuid4().hex)
    event_id = str(event["id"])
    answer_topic = reply_topic or f"{topic}/reply"
    address = parse_broker_url(broker_url)
    answers: list[dict[str, Any]] = []
    subscribed = threading.Event()
    arrived = threading.Condition()

    def on_message(_client: Any, _userdata: Any, msg: Any) -> None:
        try:
            answer = json.loads(msg.payload)
        except ValueError:
            return
        if isinstance(answer, dict) and answer.get("id") == event_id:
            with arrived:
                answers.append(answer)
                arrived.notify_all()

    client = new_client(client_id or f"mrss-request-{os.getpid()}", address)
    client.on_message = on_message
    # (again after a reconnect: a restarted broker forgot the subscription)
    client.on_connect = lambda c, *_args: c.subscribe(answer_topic, qos=1)
    client.on_subscribe = lambda *_args: subscribed.set()
    start_client(client, address, broker_url, topic)
    try:
        if not subscribed.wait(within):
            raise MrssError(f"{answer_topic}: the broker {broker_url} did not confirm the "
                            f"subscription within {within:g} s")
        deadline = time.monotonic() + patience
        text = json.dumps(event)
        while True:
            client.publish(topic, text, qos=1)
            with arrived:
                if arrived.wait_for(lambda: bool(answers),
                                    min(within, max(0.0, deadline - time.monotonic()))):
                    return answers[0]
            if time.monotonic() >= deadline:
                raise MrssError(f"{topic}: no answer on {answer_topic} for event {event_id} "
                                f"within {patience:g} s (does the project set [events] "
                                f"reply_accepted = true?)")
    finally:
        client.disconnect()
        client.loop_stop()
