"""Base classes a project subclasses: `ExternalAdapter` (events.py) and `DataLayer` (datalayer.py).

An external adapter turns outside events into percepts (paper IV-B):

    class Adapter(ExternalAdapter):
        def start(self) -> None:
            self.map_json("ui/area", "area_goal_received",
                          Field("area", "atom"), Field("priority", "int"))
            self.on_json("ui/cancel", self.cancel)

        def cancel(self, topic: str, obj: dict) -> None:
            self.percept("goal_cancelled", Atom(obj["goal"]))

Handlers run on the events manager's intake thread, one event at a time in arrival
order (`mrss.edge.intake`). A handler that raises is counted and logged with its topic;
percepts it published before failing are dropped. A `PayloadError`/`PredicateError`/
`ValueError`/`KeyError`/`TypeError` counts as a bad payload and is reported back to the
sender at once; `DependencyUnavailable` (e.g. `WorldModelUnavailable` from
`self.world_model()`), `TimeoutError` and `ConnectionError` make the event be tried again
with backoff, and reported as failed once the retry budget is spent (`mrss.edge.retry`);
anything else is a handler error. None of them stops the component.

A data layer answers grounding requests and external function calls, and forwards robot
telemetry to the world model (paper IV-C):

    class Data(DataLayer):
        @external("distance")
        def distance(self, a: str, b: str) -> float: ...
"""

from __future__ import annotations

import inspect
import logging
from collections.abc import Callable, Mapping
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Protocol, TypeVar

from mrss.edge.intake import EventIntake, InboundEvent
from mrss.edge.mqtt_client import Delivery, MqttClient
from mrss.edge.payloads import Field, JsonMapping, decode_json_object
from mrss.edge.percepts import EventCounters, PerceptPublisher
from mrss.edge.predicates import Term
from mrss.edge.retry import BAD_INPUT, Attempt
from mrss.edge.worldmodel_access import WorldModelClient
from mrss.errors import ConfigError

__all__ = ["BAD_INPUT", "DataLayer", "DataLayerContext", "EventsContext", "ExternalAdapter",
           "WorldModelAccess", "external"]
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


class ExternalAdapter:
    """A project's translator from outside events to percepts; override `start`."""

    def __init__(self, context: EventsContext) -> None:
        self.context = context
        self.percept = context.percept
        self.options = context.options
        self.log = context.log
        self.counters: EventCounters = context.percept.counters
        self.intake = context.intake or EventIntake(context.percept, log=context.log)

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

        def take(delivery: Delivery) -> None:
            event = InboundEvent(delivery.topic, delivery.payload, delivery.redelivered,
                                 acknowledge=lambda: mqtt.ack(delivery))
            self.intake.submit(event, lambda: handler(delivery.topic, delivery.payload))
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
            self.percept(declared.literal(payload, topic=topic), op=op)
        self.on_message(topic_filter, to_percept)
        return declared

    def handle(self, topic: str, work: Callable[[], None]) -> bool:
        """Run `work` once, now, for a message on `topic` (no retry, no report):
        percepts only if it succeeds; True if it did."""
        self.counters.received += 1
        return self.intake.run_once(topic, work)[0] is Attempt.ACCEPTED


class WorldModelAccess(Protocol):
    """A world model as the data layer sees it: plain JSON objects by id and kind."""

    def get(self, object_id: str) -> dict[str, Any] | None: ...

    def objects(self, kind: str | None = None) -> list[dict[str, Any]]: ...

    def upsert(self, obj: dict[str, Any]) -> dict[str, Any]: ...

    def near(self, lat: float, lon: float, radius_m: float,
             kind: str | None = None) -> list[dict[str, Any]]: ...


@dataclass
class DataLayerContext:
    """What the data layer component hands the project's DataLayer."""

    world: WorldModelAccess | None
    percept: PerceptPublisher | None = None
    options: Mapping[str, Any] = field(default_factory=dict)
    project_dir: Path | None = None
    log: logging.Logger = field(default_factory=lambda: logging.getLogger("mrss.datalayer"))


F = TypeVar("F", bound=Callable[..., Any])
_EXTERNAL_ATTR = "_mrss_external_name"
POSITION_KEYS = ("lat", "lon", "alt")


def external(name: str | None = None) -> Callable[[F], F]:
    """Mark a DataLayer method as an external function callable as `name` (default: its own)."""
    def mark(method: F) -> F:
        setattr(method, _EXTERNAL_ATTR, name or method.__name__)
        return method
    return mark


class DataLayer:
    """A project's symbol and data layer. The defaults ground ids from the world model.

    Built-in functions: `ping()`, `ground(id)`, `objects(kind)`, `near(lat, lon, radius_m,
    kind)`. A project adds its own with `@external`; a lookup that fails raises (the
    caller gets an error reply with the message).
    """

    def __init__(self, context: DataLayerContext) -> None:
        self.context = context
        self.options = context.options
        self.log = context.log

    @property
    def world(self) -> WorldModelAccess:
        """The world model; ConfigError when the deployment has none."""
        if self.context.world is None:
            raise ConfigError("no world model is configured", key="datalayer.world_model")
        return self.context.world

    def start(self) -> None:
        """Connect to external systems (called once before requests flow)."""

    def stop(self) -> None:
        """Release what `start` acquired."""

    def functions(self) -> dict[str, Callable[..., Any]]:
        """Every callable function by name: the built-ins and the `@external` methods."""
        table: dict[str, Callable[..., Any]] = {}
        for attr in dir(type(self)):
            raw = inspect.getattr_static(self, attr, None)
            name = getattr(raw, _EXTERNAL_ATTR, None)
            if isinstance(name, str):
                table[name] = getattr(self, attr)
        return table

    @external()
    def ping(self) -> str:
        """Liveness probe."""
        return "pong"

    @external()
    def ground(self, object_id: str) -> Any:
        """The data behind an object id (the world model object by default)."""
        if not isinstance(object_id, str):
            raise TypeError("object id must be a string")
        obj = self.world.get(object_id)
        if obj is None:
            raise LookupError(f"no object {object_id!r} in the world model")
        return obj

    @external()
    def objects(self, kind: str | None = None) -> list[dict[str, Any]]:
        """Every object of a kind (all objects without one)."""
        return self.world.objects(kind)

    @external()
    def near(self, lat: float, lon: float, radius_m: float,
             kind: str | None = None) -> list[dict[str, Any]]:
        """Objects within a radius of a point, nearest first."""
        return self.world.near(lat, lon, radius_m, kind)

    def on_telemetry(self, robot: str, data: Mapping[str, Any]) -> None:
        """Robot telemetry: by default the robot's world model object is updated with it.

        `lat`/`lon`/`alt` become its position; everything else merges into attributes.
        With the embedded world model the write is not waited for (writes stay in order).
        """
        if self.context.world is None:
            return
        obj: dict[str, Any] = {"id": robot, "kind": "robot",
                               "attributes": {k: v for k, v in data.items()
                                              if k not in POSITION_KEYS}}
        if "lat" in data and "lon" in data:
            obj["position"] = {k: data[k] for k in POSITION_KEYS if k in data}
        # Over the bus the write is sent without waiting for its answer: telemetry needs
        # none, and a round trip per record would cap a fleet's telemetry rate.
        write = getattr(self.world, "upsert_nowait", None) or self.world.upsert
        write(obj)
