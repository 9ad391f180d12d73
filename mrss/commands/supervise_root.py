"""The root supervisor of `mrss supervise`, running: its bus publisher, event outbox,
incident recorder and remote control around a `ProcessSupervisor`.

`mrss.commands.supervise` imports this module only once the fork server is started, so
that both import what they need at the same time (on two cores); see
docs/supervision.md, "Start".
"""

from __future__ import annotations

import logging
import signal
import sys
from pathlib import Path
from types import FrameType
from typing import Any

from mrss import logs
from mrss.bus import BusEndpoints, Publisher
from mrss.bus.settings import endpoints_from_config
from mrss.config.kinds import ComponentKind
from mrss.config.nodes import root_children
from mrss.config.operator import SECTION as OPERATOR_SECTION
from mrss.config.operator import operator_topics
from mrss.config.project import ProjectConfig
from mrss.messages import IncarnationKey
from mrss.runtime.incident_recorder import IncidentRecorder
from mrss.runtime.operator_guard import OperatorGuard
from mrss.runtime.remote import RemoteControl
from mrss.supervision.children import ProcessSettings
from mrss.supervision.cpu_latency import cpu_latency
from mrss.supervision.events import Publish
from mrss.supervision.launchers import ForkLauncher, become_subreaper
from mrss.supervision.outbox import EventOutbox
from mrss.supervision.process import ProcessSupervisor

EXIT_GAVE_UP = 1


def build_supervisor(
    config: ProjectConfig, run_dir: Path, *, launcher: str | None = None,
    publish: Publish | None = None, bus: dict[str, Any] | None = None, node: str = "",
    key: IncarnationKey | None = None, fork_server: ForkLauncher | None = None,
) -> ProcessSupervisor:
    """The root supervisor for a validated project (of one node's share, with `node`).

    `publish` receives every sup.* event (a bus Publisher's `publish`); `bus` is the
    endpoints dict handed to every component as `ctx.bus`; `key` the run's incarnation
    key (its path is in `bus`), which proves each start it announces; `fork_server` a
    fork launcher started early for the same children.
    """
    s = config.supervisor
    settings = ProcessSettings(
        project_dir=config.directory, run_dir=run_dir, bus=dict(bus or {}),
        heartbeat_interval=s.heartbeat_interval, heartbeat_misses=s.heartbeat_misses,
        launcher="exec" if (launcher or s.launcher) == "exec" else "fork", key=key,
    )
    return ProcessSupervisor(config.name, s.spec, root_children(config, node), settings,
                             publish=publish, node=node or None,
                             fork_server=fork_server if settings.launcher == "fork" else None)


def supervise(config: ProjectConfig, run_dir: Path, launcher: str | None,
              early: list[int], node: str = "", server: ForkLauncher | None = None) -> int:
    """Run the root supervisor of a checked project until it stops; the exit code."""
    endpoints = endpoints_from_config(config.sections.get("bus", {}), run_dir,
                                      file=str(config.file), nodes=bool(node))
    # The root is the authority for incarnations: a fresh key per run (docs/bus.md, "Who
    # may claim an incarnation"). With [nodes], each node's root has its own, and the
    # nodes' proxies translate proofs at the border (mrss/bus/border.py).
    key = IncarnationKey.create(run_dir)
    endpoints = endpoints.keyed(key.path)
    publisher = Publisher(endpoints, src="supervisor", watch_subscriptions=True)
    to_bus = logs.install_bus_handler(logs.BusLogHandler(config.name, publisher.publish))
    outbox = None
    publish: Publish = publisher.publish
    bus_child = proxy_child(config)
    if bus_child:
        outbox = EventOutbox(publisher.publish, bus_child, publisher.subscriptions)
        publish = outbox
    incident = incident_recorder(config, run_dir, endpoints)
    publish = incident.publishing(publish)
    try:
        sup = build_supervisor(config, run_dir, launcher=launcher, publish=publish,
                               bus=endpoints.to_dict(), node=node, key=key,
                               fork_server=server)
        server = None  # the supervisor's now
        remote = RemoteControl(sup, endpoints, publisher.publish,  # ctl.tree, ctl.fault
                               OperatorGuard(config.directory,
                                             logging.getLogger("mrss.supervise"))).start()
        try:
            with cpu_latency(config.supervisor.cpu_latency_us):
                return run_root(config, run_dir, sup, early)
        finally:
            remote.close()
    finally:
        if server is not None:
            server.close()
        incident.close()
        if outbox is not None:
            outbox.close()
        logs.remove_bus_handler(to_bus)
        publisher.close()


def incident_recorder(config: ProjectConfig, run_dir: Path,
                      endpoints: BusEndpoints) -> IncidentRecorder:
    """The run's incident recorder, started (docs/mission.md, "The incident record")."""
    topics = operator_topics(config.sections.get(OPERATOR_SECTION))
    return IncidentRecorder(run_dir, endpoints, project=config.name, operator_topics=topics,
                            components=[c.id for c in config.components],
                            project_dir=config.directory).start()


def proxy_child(config: ProjectConfig) -> str:
    """The id of the component that runs the bus proxy ("" if the project has none)."""
    return next((c.id for c in config.components
                 if c.enabled and c.kind is ComponentKind.BUS), "")


def run_root(config: ProjectConfig, run_dir: Path, sup: ProcessSupervisor,
              interrupts: list[int]) -> int:

    def on_signal(signum: int, frame: FrameType | None) -> None:
        interrupts.append(signum)
        sup.request_stop(force=len(interrupts) > 1)  # a second signal kills at once

    signal.signal(signal.SIGINT, on_signal)
    signal.signal(signal.SIGTERM, on_signal)
    become_subreaper()  # a lost fork server's children stay ours (and in our tree)
    if interrupts:  # signalled while starting up: stop (or kill, if twice) at once
        sup.request_stop(force=len(interrupts) > 1)
    logging.getLogger("mrss.supervise").info(
        "supervising %s (%d components), run dir %s", config.name,
        len(config.child_specs()), run_dir)
    outcome = sup.run()
    if outcome.gave_up:
        print(f"mrss supervise: {config.name}: {outcome}", file=sys.stderr)
        return EXIT_GAVE_UP
    logging.getLogger("mrss.supervise").info("all components stopped")
    return 0
