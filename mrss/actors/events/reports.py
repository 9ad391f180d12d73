"""Telling the sender and the dashboard what became of an external event.

Every event the intake finishes is reported three ways (`EventReporter.report`):

- on the bus, an `mrss.messages.EventReport` on `edge.<status>` (for the dashboard,
  `mrss record` and `mrss chaos`);
- in the log with a stable event name: `event_failed ...` at ERROR, `event_rejected ...`
  at WARNING (once per topic and reason per minute; the others are counted and
  summarised, `mrss.edge.rejections`), `event_duplicate ...` at INFO (`accepted` at
  DEBUG); records at INFO and above reach the dashboard's log as `LogRecord`s;
- back to the sender on MQTT, for `rejected` and `failed` (and `accepted` and
  `duplicate` with `[events] reply_accepted = true`, so a sender that sends again
  because an answer was lost is answered too): a JSON object on the reply topic
  `[events] reply_topic` (default `"{topic}/reply"`, `{topic}` being the event's topic;
  `""` turns replies off):

      {"status": "failed", "topic": "mrss/ui/area", "id": "op-17", "goal": "a1",
       "reason": "world model unavailable: ...", "attempts": 9, "component": "events"}

  (`id` is the sender's `"id"`, `goal` its `"goal"`, each only when the payload had it.)

A reply topic never counts as an event (`is_reply_topic`), so an adapter subscribed with
a wildcard does not answer its own replies.
"""

from __future__ import annotations

import json
import logging
from collections.abc import Mapping
from typing import Any, Protocol

from mrss.edge.rejections import RejectionLog
from mrss.errors import ConfigError
from mrss.messages import EventReport, EventStatus, JsonValue
from mrss.runtime.busport import MessagePublisher

DEFAULT_REPLY_TOPIC = "{topic}/reply"
REPLIED = frozenset({EventStatus.REJECTED, EventStatus.FAILED})
LOG_LEVELS = {EventStatus.ACCEPTED: logging.DEBUG, EventStatus.DUPLICATE: logging.INFO,
              EventStatus.REJECTED: logging.WARNING, EventStatus.FAILED: logging.ERROR}


def refusal_kind(reason: str) -> str:
    """What a refused event is counted as: its reason up to the first colon, after the
    "cannot decode message on topic ..." every payload error starts with (the field or
    check, e.g. "field 'robot'", "payload is not JSON"), not the values in it."""
    head, colon, rest = reason.partition(": ")
    if colon and head.startswith("cannot decode message"):
        reason = rest
    return reason.split(":", 1)[0]


class ReplyPublisher(Protocol):
    """Publishes an MQTT message (`mrss.edge.mqtt_client.MqttClient` is one)."""

    def publish(self, topic: str, payload: bytes | str, qos: int = 1,
                retain: bool = False) -> bool: ...


def reply_template(section: Mapping[str, Any]) -> str:
    """The `[events] reply_topic` template ("" when replies are off)."""
    template = section.get("reply_topic", DEFAULT_REPLY_TOPIC)
    if not isinstance(template, str) or "+" in template or "#" in template \
            or template.count("{topic}") > 1 \
            or template.replace("{topic}", "").count("{") \
            or template.replace("{topic}", "").count("}"):
        raise ConfigError("must be an MQTT topic without wildcards, with at most one "
                          "'{topic}' placeholder", key="events.reply_topic")
    return template


class EventReporter:
    """Reports finished events on the bus, in the log and back to the sender."""

    def __init__(self, component: str, *, bus: MessagePublisher | None = None,
                 replies: ReplyPublisher | None = None, reply_topic: str = DEFAULT_REPLY_TOPIC,
                 reply_accepted: bool = False, log: logging.Logger | None = None) -> None:
        self.component = component
        self._bus = bus
        self._replies = replies
        self.reply_topic = reply_topic
        self.replied = REPLIED | ({EventStatus.ACCEPTED, EventStatus.DUPLICATE}
                                  if reply_accepted else set())
        self.log = log or logging.getLogger("mrss.events")
        self.rejections = RejectionLog(self.log, "event")

    def reply_topic_for(self, topic: str) -> str | None:
        """Where the answer to an event on `topic` goes (None: replies are off)."""
        if not self.reply_topic:
            return None
        return self.reply_topic.replace("{topic}", topic)

    def is_reply_topic(self, topic: str) -> bool:
        """Whether `topic` is where this reporter answers (never an event itself)."""
        template = self.reply_topic
        if not template:
            return False
        if "{topic}" not in template:
            return topic == template
        head, tail = template.split("{topic}")
        return len(topic) > len(head) + len(tail) and topic.startswith(head) \
            and topic.endswith(tail)

    def refused(self, topic: str, reason: str) -> None:
        """Count (and log, once per topic and kind per interval) a bad payload that is
        not reported otherwise."""
        self.rejections.reject(topic, refusal_kind(reason), reason)

    def report(self, status: EventStatus, topic: str, *, event_id: str = "",
               reason: str = "", attempts: int = 0,
               detail: Mapping[str, JsonValue] | None = None) -> None:
        """Tell the bus, the log and (for the statuses replied to) the sender."""
        extra = dict(detail or {})
        if status is EventStatus.REJECTED and self.rejections.seen(topic, refusal_kind(reason)):
            pass  # counted; summarised by the rejection log
        else:
            self.log.log(LOG_LEVELS[status], "event_%s topic=%s id=%s attempts=%d%s%s",
                         status.value, topic, event_id or "-", attempts,
                         "".join(f" {k}={v}" for k, v in extra.items()),
                         f": {reason}" if reason else "")
        if self._bus is not None:
            try:
                self._bus.publish(EventReport(
                    component=self.component, status=status.value, event_topic=topic,
                    event_id=event_id, reason=reason, attempts=attempts, detail=extra))
            except Exception as exc:  # the log line above still tells
                self.log.warning("event report for %r not published: %r", topic, exc)
        reply_topic = self.reply_topic_for(topic)
        if status in self.replied and self._replies is not None and reply_topic:
            answer: dict[str, JsonValue] = {"status": status.value, "topic": topic}
            if event_id:
                answer["id"] = event_id
            answer.update(extra)
            answer.update(reason=reason, attempts=attempts, component=self.component)
            if not self._replies.publish(reply_topic, json.dumps(answer).encode(), qos=1):
                self.log.warning("reply to %r on %r could not be queued", topic, reply_topic)
