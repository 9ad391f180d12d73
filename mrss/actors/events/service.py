"""The External Events Manager component (paper IV-B): the project's adapter, run.

It imports the project's `ExternalAdapter` subclass from `projects/<name>/events.py`
(only from the project folder), gives it a percept publisher, an MQTT client for the
project's broker and an event intake, and runs it. Bad payloads are the adapter's
business to reject; the manager counts them (`stats()`) and keeps serving.

No silent drops (docs/edges.md, "Delivery guarantees"):
- MQTT: QoS 1 subscriptions in a persistent session (clean_session false, client id
  `mrss-<project>-<component>`), each message acknowledged only once the intake has
  an outcome for it and the reasoner has its percepts in its ledger, so nothing in hand
  is lost when this process (or the reasoner) dies: the broker delivers it again;
- the intake (`mrss.actors.events.intake`) handles events in order, de-duplicates
  redeliveries, retries those whose dependency is down, and reports every outcome
  on the bus and (rejected, failed) back to the sender on the reply topic;
- percepts go to the reasoner on the reliable channel "percept", with a copy on the
  plain `percept` topic (`mrss.runtime.percept_channel`).

project.toml:
    [broker]  url = "mqtt://..."     # absent: the embedded broker's (<run_dir>/broker.url)
    [events]  module = "events.py"   # default; class = "Name" when the file has several
              retry_budget = 30.0    # seconds an event may wait for a dependency
              retry_initial = 0.2    # first backoff (doubles up to retry_max_delay)
              retry_max_delay = 5.0
              reply_topic = "{topic}/reply"   # "" : no replies to the sender
              reply_accepted = false # also reply when an event was accepted
              persistent_session = true
              client_id = "..."      # default mrss-<project>-<component>
              dedup_memory = 4096    # event identities remembered
              world_model = "http://..."      # for self.world_model(); default: the run's
              world_model_timeout = 2.0
              robots = ["uav1"]      # robots events may name; default: the RCL's robots
              ...                    # every key but module/class is the adapter's `options`
The `[components.<id>]` free keys of this component are laid over `[events]`.
"""

from __future__ import annotations

import logging
import os
from collections.abc import Callable, Mapping
from pathlib import Path
from typing import Any, ClassVar

from mrss.actors.events.adapter import EventsContext, ExternalAdapter
from mrss.actors.events.intake import EventIntake
from mrss.actors.events.operator_commands import (
    declared_commands,
    operator_check,
    operator_topics,
    serve_commands,
)
from mrss.actors.events.reports import EventReporter, reply_template
from mrss.config.broker import table, with_broker
from mrss.edge.http_token import configured_token
from mrss.edge.mqtt_client import MqttClient, MqttSettings
from mrss.edge.retry import RetryPolicy
from mrss.errors import ConfigError
from mrss.messages import Percept
from mrss.options import Check, Option, OptionValues
from mrss.runtime.busport import BusPort, MessagePublisher, bus_port
from mrss.runtime.component import Component, ComponentContext
from mrss.runtime.edge import edge_config, project_robots
from mrss.runtime.loader import load_project_class
from mrss.runtime.operator_guard import OperatorGuard
from mrss.runtime.percept_channel import PerceptChannel
from mrss.runtime.percepts import EventCounters, PerceptPublisher, PerceptSink

DEFAULT_MODULE = "events.py"
PERCEPT_FLUSH = 1.0  # seconds a stopping manager gives its last percepts to be acknowledged


def _robots(section: Mapping[str, Any], project_dir: Path) -> frozenset[str] | None:
    """`[events] robots`, else the project's (the RCL's robots tables); None: none known."""
    listed = section.get("robots")
    if listed is None:
        return project_robots(project_dir) or None
    if not isinstance(listed, list) or not all(isinstance(r, str) for r in listed):
        raise ConfigError("must be a list of robot ids", key="events.robots")
    return frozenset(listed)


class ExternalEventsManager(Component):
    """Component: loads and runs the project's external adapter."""

    #: The options this component reads (`mrss check` validates them; docs/config.md).
    SECTION: ClassVar[str] = "events"  # read from [events], under its own table's keys
    OPTIONS: ClassVar[tuple[Option, ...]] = (
        Option("module", str, "events.py", "the project's ExternalAdapter file",
               Check.PROJECT_FILE),
        Option("class", str, None, "the ExternalAdapter subclass, when the file has several"),
        Option("retry_budget", float, 30.0, "seconds an event may wait for a dependency",
               Check.NON_NEGATIVE),
        Option("retry_initial", float, 0.2, "first retry delay (doubles)", Check.POSITIVE),
        Option("retry_max_delay", float, 5.0, "longest retry delay", Check.POSITIVE),
        Option("reply_topic", str, "{topic}/reply",
               "where a sender hears of its event (\"\": nowhere)"),
        Option("reply_accepted", bool, False, "also reply when an event was accepted"),
        Option("persistent_session", bool, True, "keep the MQTT session across restarts"),
        Option("client_id", str, None, "MQTT client id (default mrss-<project>-<component>)"),
        Option("dedup_memory", int, 4096, "event identities remembered", Check.POSITIVE),
        Option("world_model", str, None, "world model URL for self.world_model()", Check.URL),
        Option("world_model_timeout", float, 2.0, "seconds per world model call", Check.POSITIVE),
        Option("robots", list, None, "robot ids events may name (default: the RCL's robots)"),
    )

    def __init__(self) -> None:
        self.counters = EventCounters()
        self.adapter: ExternalAdapter | None = None
        self.mqtt: MqttClient | None = None
        self.intake: EventIntake | None = None
        self.percepts: PerceptChannel | None = None
        self._bus: BusPort | None = None
        self.log = logging.getLogger("mrss.events")

    def start(self, ctx: ComponentContext) -> None:
        """Component entry: bus and percept channel from the context, then `run`."""
        self.log = ctx.log
        config = with_broker(edge_config(ctx, "events"), ctx.run_dir)
        self._bus = bus_port(ctx)
        self.percepts = PerceptChannel.for_component(ctx)
        values = OptionValues(self.OPTIONS, table(config, "events"), section="events")
        client_id = values.text("client_id") or f"mrss-{ctx.project_dir.name}-{ctx.name}"
        self.run(ctx.project_dir, config, self._bus, client_id=client_id,
                 run_dir=ctx.run_dir, percepts=self.percepts.send, component=ctx.name,
                 durable=self.percepts.when_durable)

    def run(self, project_dir: Path, config: Mapping[str, Any], publisher: MessagePublisher,
            *, client_id: str | None = None, run_dir: Path | None = None,
            percepts: PerceptSink | None = None, component: str = "events",
            durable: Callable[[Callable[[], object]], object] | None = None) -> None:
        """Load the adapter, connect MQTT (if a broker is configured), start the adapter.

        With a `client_id` the MQTT session is persistent (unless `[events]
        persistent_session = false`); without one it is a throwaway session. Percepts go
        to `percepts` (default: published on `publisher`), event reports on `publisher`;
        with `durable` (the percept channel's `when_durable`) an MQTT message is
        acknowledged only once its percepts are in the reasoner's ledger.
        """
        events = table(config, "events")
        values = OptionValues(self.OPTIONS, events, section="events")
        broker = table(config, "broker")
        adapter_cls = load_project_class(project_dir, values.text("module"), ExternalAdapter,
                                         class_name=values["class"], key="events.module")
        policy = RetryPolicy.from_config(events)
        template = reply_template(events)
        reply_accepted = values.flag("reply_accepted")
        persistent = client_id is not None and values.flag("persistent_session")
        if broker.get("url"):
            settings = MqttSettings.from_config(broker)
            self.mqtt = MqttClient(settings, client_id=client_id or f"mrss-events-{os.getpid()}",
                                   logger=self.log, clean_session=not persistent,
                                   manual_ack=True)

        def to_bus(percept: Percept, _msg_id: str | None) -> None:
            publisher.publish(percept)

        publish = PerceptPublisher(percepts or to_bus, self.counters)
        reporter = EventReporter(component, bus=publisher, replies=self.mqtt,
                                 reply_topic=template, reply_accepted=reply_accepted,
                                 log=self.log)
        self.intake = EventIntake(publish, policy=policy, reporter=reporter, log=self.log,
                                  memory=values.whole("dedup_memory"), durable=durable)
        options = {k: v for k, v in events.items() if k not in ("module", "class")}
        token = configured_token(table(config, "worldmodel"), project_dir)
        self.adapter = adapter_cls(EventsContext(
            percept=publish, mqtt=self.mqtt, options=options, project_dir=project_dir,
            broker_url=self.mqtt.settings.url if self.mqtt else None, log=self.log,
            run_dir=run_dir, intake=self.intake, world_model_token=token,
            robots=_robots(events, project_dir),
            operator_check=operator_check(OperatorGuard(project_dir, self.log),
                                          operator_topics(project_dir))))
        self.intake.start()
        self.adapter.start()  # subscriptions first, so the first (re)connect sends them all
        commands = declared_commands(project_dir)  # [operator.commands]: checked percepts
        if commands and self.mqtt is not None:
            serve_commands(self.adapter, commands)
        elif commands:
            self.log.warning("[operator.commands] declared but no MQTT broker: the "
                             "dashboard's forms cannot reach the agent")
        if self.mqtt is not None:
            self.mqtt.start()
        self.log.info("external adapter %s running (broker %s)", adapter_cls.__name__,
                      self.mqtt.settings.url if self.mqtt else "none")

    def stats(self) -> dict[str, object]:
        """Counters: messages received, percepts published, bad payloads (also by topic)."""
        return self.counters.snapshot()

    def stop(self) -> None:
        """Stop taking events (those not finished are redelivered to the next
        incarnation), then the adapter, the MQTT client and the percept channel."""
        try:
            if self.intake is not None:
                self.intake.stop()
            if self.adapter is not None:
                self.adapter.stop()
        finally:
            if self.percepts is not None:  # its acknowledgements go out while MQTT is up
                self.percepts.flush(PERCEPT_FLUSH)
            if self.mqtt is not None:
                self.mqtt.stop()
            if self.percepts is not None:
                self.percepts.close()
            if self._bus is not None:
                self._bus.close()
            self.log.info("external adapter stopped: %s", self.stats())
