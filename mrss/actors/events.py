"""The External Events Manager component (paper IV-B): the project's adapter, run.

It imports the project's `ExternalAdapter` subclass from `projects/<name>/events.py`
(only from the project folder), gives it a percept publisher bound to the bus and an
MQTT client for the project's broker, and runs it. Bad payloads are the adapter's
business to reject; the manager counts them (`stats()`) and keeps serving.

project.toml:
    [broker]  url = "mqtt://..."     # absent: the embedded broker's (<run_dir>/broker.url)
    [events]  module = "events.py"   # default; class = "Name" when the file has several
              ...                    # every other key is the adapter's `options`
The `[components.<id>]` free keys of this component are laid over `[events]`.
"""

from __future__ import annotations

import logging
import os
from collections.abc import Mapping
from pathlib import Path
from typing import Any

from mrss.edge.adapters import EventsContext, ExternalAdapter
from mrss.edge.busport import BusPort, MessagePublisher
from mrss.edge.component import bus_port, edge_config, table, with_broker
from mrss.edge.loader import load_project_class
from mrss.edge.mqtt_client import MqttClient, MqttSettings
from mrss.edge.percepts import EventCounters, PerceptPublisher
from mrss.messages import Percept
from mrss.supervision.component import Component, ComponentContext

DEFAULT_MODULE = "events.py"


class ExternalEventsManager(Component):
    """Component: loads and runs the project's external adapter."""

    def __init__(self) -> None:
        self.counters = EventCounters()
        self.adapter: ExternalAdapter | None = None
        self.mqtt: MqttClient | None = None
        self._bus: BusPort | None = None
        self.log = logging.getLogger("mrss.events")

    def start(self, ctx: ComponentContext) -> None:
        """Component entry: bus from the context, then `run`."""
        self.log = ctx.log
        config = with_broker(edge_config(ctx, "events"), ctx.run_dir)
        self._bus = bus_port(ctx)
        self.run(ctx.project_dir, config, self._bus, client_id=f"mrss-{ctx.name}",
                 run_dir=ctx.run_dir)

    def run(self, project_dir: Path, config: Mapping[str, Any], publisher: MessagePublisher,
            *, client_id: str = "mrss-events", run_dir: Path | None = None) -> None:
        """Load the adapter, connect MQTT (if a broker is configured), start the adapter."""
        events = table(config, "events")
        broker = table(config, "broker")
        adapter_cls = load_project_class(project_dir, str(events.get("module", DEFAULT_MODULE)),
                                         ExternalAdapter, class_name=events.get("class"),
                                         key="events.module")
        if broker.get("url"):
            settings = MqttSettings.from_config(broker)
            self.mqtt = MqttClient(settings, client_id=f"{client_id}-{os.getpid()}",
                                   logger=self.log)

        def to_bus(percept: Percept) -> None:
            publisher.publish(percept)

        percepts = PerceptPublisher(to_bus, self.counters)
        options = {k: v for k, v in events.items() if k not in ("module", "class")}
        self.adapter = adapter_cls(EventsContext(
            percept=percepts, mqtt=self.mqtt, options=options, project_dir=project_dir,
            broker_url=self.mqtt.settings.url if self.mqtt else None, log=self.log,
            run_dir=run_dir))
        self.adapter.start()  # subscriptions first, so the first (re)connect sends them all
        if self.mqtt is not None:
            self.mqtt.start()
        self.log.info("external adapter %s running (broker %s)", adapter_cls.__name__,
                      self.mqtt.settings.url if self.mqtt else "none")

    def stats(self) -> dict[str, object]:
        """Counters: messages received, percepts published, bad payloads (also by topic)."""
        return self.counters.snapshot()

    def stop(self) -> None:
        """Stop the adapter, then the MQTT client."""
        try:
            if self.adapter is not None:
                self.adapter.stop()
        finally:
            if self.mqtt is not None:
                self.mqtt.stop()
            if self._bus is not None:
                self._bus.close()
            self.log.info("external adapter stopped: %s", self.stats())
