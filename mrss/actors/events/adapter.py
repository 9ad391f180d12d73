"""The base class of a project's events.py: `ExternalAdapter`, and what it is handed.

An external adapter turns outside events into percepts (paper IV-B):

    class Adapter(ExternalAdapter):
        def start(self) -> None:
            self.map_json("ui/area", "area_goal_received",
                          Field("area", "atom"), Field("priority", "int"))
            self.on_json("ui/cancel", self.cancel)

        def cancel(self, topic: str, obj: dict) -> None:
            self.percept("goal_cancelled", Atom(obj["goal"]))

Handlers run on the events manager's intake thread, one event at a time in arrival
order (`mrss.actors.events.intake`). A handler that raises is counted and logged with its topic;
percepts it published before failing are dropped. A `PayloadError`/`PredicateError`/
`ValueError`/`KeyError`/`TypeError` counts as a bad payload and is reported back to the
sender at once; `DependencyUnavailable` (e.g. `WorldModelUnavailable` from
`self.world_model()`), `TimeoutError` and `ConnectionError` make the event be tried again
with backoff, and reported as failed once the retry budget is spent (`mrss.edge.retry`);
anything else is a handler error. None of them stops the component.
"""

from __future__ import annotations

import logging
from collections.abc import Callable, Mapping
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from mrss.actors.events.intake import EventIntake, InboundEvent
from mrss.agentspeak.literals import Term
from mrss.edge.mqtt_client import Delivery, MqttClient
from mrss.edge.payloads import Field, JsonMapping, decode_json_object
from mrss.edge.retry import BAD_INPUT, Attempt
from mrss.errors import ConfigError
from mrss.runtime.percepts import EventCounters, PerceptPublisher
from mrss.world.access import WorldModelClient

__all__ = ["BAD_INPUT", "EventsContext", "ExternalAdapter"]
DEFAULT_WORLD_MODEL_TIMEOUT = 2.0
JsonHandler = Callable[[str, dict[str, Any]], None]
RawHandler = Callable[[str, bytes], None]


@dataclass
class EventsContext:
    """What the events manager hands its adapter."""

    percept: PerceptPublisher
    mqtt: MqttClient | None
    options: Mapping[str, Any] = field(default_factory=dict)
    project_dir: Path | None = None
    broker_url: str | None = None
    log: logging.Logger = field(default_factory=lambda: logging.getLogger("mrss.events"))
    run_dir: Path | None = None  # the run folder (worldmodel.url, ...), when supervised
    intake: EventIntake | None = None  # None: the adapter makes a plain one
    world_model_token: str | None = None  # [worldmodel] token: sent by world_model()
    robots: frozenset[str] | None = None  # the project's robots (None: not known)
    # the check of operator commands' authors (mrss.actors.events.operator_commands):
    # the payload to handle, or PayloadError; None: none
    operator_check: Callable[[str, bytes], bytes] | None = None


class ExternalAdapter:
    """A project's translator from outside events to percepts; override `start`."""

    def __init__(self, context: EventsContext) -> None:
        self.context = context
        self.percept = context.percept
        self.options = context.options
        self.log = context.log
        self.counters: EventCounters = context.percept.counters
        self.intake = context.intake or EventIntake(context.percept, log=context.log)
        #: The robots of the project (`[events] robots`, else the RCL's robots tables),
        #: None when none is configured. A `Field(..., "robot")` of a mapping names one
        #: of them: `map_json` checks it, a handler passes `robots=self.robots` to
        #: `JsonMapping.args`. A message about any other robot is a bad payload, refused
        #: with one reply, never a percept the agent would act on and retry.
        self.robots: frozenset[str] | None = context.robots

    @property
    def mqtt(self) -> MqttClient:
        """The MQTT client connected to the project's broker."""
        if self.context.mqtt is None:
            raise ConfigError("this events manager has no MQTT broker configured",
                              key="broker.url")
        return self.context.mqtt

    def start(self) -> None:
        """Subscribe to what the project listens to (called once, before messages flow)."""

    def stop(self) -> None:
        """Release what `start` acquired (the MQTT client is stopped by the manager)."""

    def world_model(self) -> WorldModelClient:
        """The run's world model over HTTP, found again for every call (it may restart).

        `[events] world_model = "http://..."` names a deployment's own; otherwise it is
        the embedded one of this run. Calls raise `WorldModelUnavailable` while it is
        down (the event is retried) and `WorldModelRejected` for a bad object. The
        project's world model token (`[worldmodel] token_file`) is sent with every call.
        """
        url = self.options.get("world_model")
        timeout = self.options.get("world_model_timeout", DEFAULT_WORLD_MODEL_TIMEOUT)
        if url is not None and not (isinstance(url, str) and url.startswith(("http://",
                                                                            "https://"))):
            raise ConfigError(f"{url!r} must be an http:// URL", key="events.world_model")
        if isinstance(timeout, bool) or not isinstance(timeout, (int, float)) or timeout <= 0:
            raise ConfigError("must be a positive number of seconds",
                              key="events.world_model_timeout")
        if url is None and self.context.run_dir is None:
            raise ConfigError("no world model: not running supervised and no URL given",
                              key="events.world_model")
        return WorldModelClient(run_dir=self.context.run_dir, url=url, timeout=float(timeout),
                                token=self.context.world_model_token)

    def on_message(self, topic_filter: str, handler: RawHandler) -> None:
        """Call `handler(topic, payload)` for each MQTT message, on the intake thread."""
        mqtt = self.mqtt
        check = self.context.operator_check or (lambda _topic, payload: payload)

        def take(delivery: Delivery) -> None:
            event = InboundEvent(delivery.topic, delivery.payload, delivery.redelivered,
                                 acknowledge=lambda: mqtt.ack(delivery))
            self.intake.submit(event, lambda: handler(
                delivery.topic, check(delivery.topic, delivery.payload)))
        mqtt.subscribe_deliveries(topic_filter, take)

    def on_json(self, topic_filter: str, handler: JsonHandler) -> None:
        """Like `on_message`, but the payload must be a JSON object (else a bad payload)."""
        self.on_message(topic_filter, lambda topic, payload: handler(
            topic, decode_json_object(payload, topic=topic)))

    def map_json(self, topic_filter: str, mapping: JsonMapping | str, *fields: Field,
                 op: str = "add", annotations: tuple[Term, ...] = ()) -> JsonMapping:
        """Publish one percept per JSON message, built from declared fields."""
        if isinstance(mapping, str):
            mapping = JsonMapping(mapping, *fields, annotations=annotations)
        declared = mapping

        def to_percept(topic: str, payload: bytes) -> None:
            self.percept(declared.literal(payload, topic=topic, robots=self.robots), op=op)
        self.on_message(topic_filter, to_percept)
        return declared

    def handle(self, topic: str, work: Callable[[], None]) -> bool:
        """Run `work` once, now, for a message on `topic` (no retry, no report; a bad
        payload is counted and logged with the other refusals): percepts only if it
        succeeds; True if it did."""
        self.counters.received += 1
        attempt, reason = self.intake.run_once(topic, work)
        if attempt is Attempt.BAD_INPUT:
            self.intake.reporter.refused(topic, reason)
        return attempt is Attempt.ACCEPTED
