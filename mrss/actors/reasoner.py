"""The Reasoner component: the project's AgentSpeak agent on the bus (paper IV-D).

- `percept` messages become percepts (`source(percept)`), add or remove;
  supervision's `sup.quarantine` / `sup.release` and `robot.<id>.state` availability
  become `robot_unavailable(R)` percepts;
- environment actions leave on the reliable `action` channel and block their intention
  until a terminal `action.status` (see `ReasonerHost`);
- a heartbeat with this incarnation goes out every `heartbeat` seconds: the RCL cancels
  the actions of an incarnation that is gone, so no robot works for a dead intention;
- `ctl.mind` (any target, or this reasoner's name) publishes a `mind.<name>` snapshot.

Options (the component's table in project.toml): `agent` (file, default `agent.asl`),
`beliefs` (extra initial beliefs), `lease` (seconds the RCL may be silent while actions
wait, default 10), `heartbeat` (seconds, default 0.5), `query_timeout` (seconds).
"""

from __future__ import annotations

import logging
import os
import threading
from collections.abc import Callable
from pathlib import Path
from typing import Any

from mrss.actors.reasoner_host import ReasonerHost
from mrss.agentspeak import Agent, AslSyntaxError, parse_literal
from mrss.bus import BusEndpoints, Publisher, ReliableSender, Subscriber
from mrss.edge.component import ZmqBusPort, bus_port
from mrss.edge.datalayer_client import DataLayerClient
from mrss.errors import ConfigError, MrssError
from mrss.messages import (
    ActionControl,
    ActionRequest,
    ActionStatus,
    Command,
    Envelope,
    Heartbeat,
    MindSnapshot,
    Percept,
    RobotState,
    SupEvent,
)
from mrss.supervision.component import Component, ComponentContext

log = logging.getLogger("mrss.reasoner")

ACTION_CHANNEL = "action"
RCL_PREFIX = "rcl"


def unavailable_percept(robot: str) -> str:
    return f"robot_unavailable({robot})"


class Reasoner:
    """The agent, its host and its loop thread; bus-agnostic (tests drive it directly)."""

    def __init__(self, agent_file: Path, *, name: str,
                 send_request: Callable[[ActionRequest], object],
                 send_control: Callable[[ActionControl], object],
                 data_call: Any = None, beliefs: list[str] | None = None,
                 lease: float = 10.0, query_timeout: float = 5.0,
                 on_tick: Callable[[], None] | None = None, tick: float = 0.5) -> None:
        self.host = ReasonerHost(send_request, send_control, data_call, lease=lease,
                                 query_timeout=query_timeout)
        self.agent = Agent.from_file(agent_file, host=self.host, name=name,
                                     beliefs=beliefs or [], out=self._print)
        self.host.agent = self.agent
        self.name = name
        self._on_tick = on_tick
        self._tick = tick
        self._stop = threading.Event()
        self._thread = threading.Thread(target=self._loop, name=f"{name}-loop", daemon=True)
        self._snapshot_wanted = threading.Event()
        self.snapshot_sink: Callable[[dict[str, Any]], object] | None = None

    def _print(self, line: str) -> None:
        log.info("%s: %s", self.name, line)

    def start(self) -> None:
        self._thread.start()

    def stop(self) -> None:
        self._stop.set()
        self.agent.wake()
        self._thread.join(timeout=5)
        self.host.close()

    def request_snapshot(self) -> None:
        self._snapshot_wanted.set()
        self.agent.wake()

    def _loop(self) -> None:
        agent = self.agent
        while not self._stop.is_set():
            timeout = self._tick
            deadline = agent.next_deadline()
            if deadline is not None:
                timeout = max(0.0, min(timeout, deadline - agent.clock()))
            agent.wait_for_work(timeout)
            try:
                agent.run_until_idle(max_cycles=10_000)
            except Exception:  # the agent must keep serving whatever one cycle did
                log.exception("%s: reasoning cycle failed", self.name)
            self.host.check_lease()
            if self._on_tick is not None:
                self._on_tick()
            if self._snapshot_wanted.is_set() and self.snapshot_sink is not None:
                self._snapshot_wanted.clear()
                self.snapshot_sink(agent.snapshot())

    # ------------------------------------------------------------ inputs
    def on_message(self, env: Envelope) -> None:
        """Route one bus message to the agent or the host; bad data is logged, never fatal."""
        body = env.body
        try:
            if isinstance(body, Percept):
                literal = parse_literal(body.literal)
                if body.op == "add":
                    self.agent.add_percept(literal)
                else:
                    self.agent.remove_percept(literal)
            elif isinstance(body, ActionStatus):
                self.host.on_status(body, env.inc)
            elif isinstance(body, SupEvent):
                self._on_sup(body)
            elif isinstance(body, RobotState):
                if env.src.startswith(RCL_PREFIX):
                    self.host.heard_from_rcl(env.inc)
                self._set_unavailable(body.robot, not body.available)
            elif isinstance(body, Heartbeat):
                if body.component.startswith(RCL_PREFIX):
                    self.host.heard_from_rcl(env.inc)
            elif (isinstance(body, Command) and body.command == "mind"
                  and body.target in ("", self.name)):
                self.request_snapshot()
        except (MrssError, ValueError) as exc:
            log.warning("%s: dropped %s from %s on %s: %s", self.name, env.kind, env.src,
                        env.topic, exc)

    def _on_sup(self, event: SupEvent) -> None:
        robot = event.detail.get("robot")
        if not isinstance(robot, str) or not robot:
            return
        if event.event == "quarantine":
            self._set_unavailable(robot, True)
        elif event.event == "release":
            self._set_unavailable(robot, False)

    def _set_unavailable(self, robot: str, unavailable: bool) -> None:
        literal = unavailable_percept(robot)
        if unavailable:
            self.agent.add_percept(literal)
        else:
            self.agent.remove_percept(literal)


class ReasonerComponent(Component):
    """The reasoner as an OS process under the root supervisor."""

    def __init__(self) -> None:
        self.reasoner: Reasoner | None = None
        self._tx: ReliableSender | None = None
        self._sub: Subscriber | None = None
        self._data: DataLayerClient | None = None
        self._port: ZmqBusPort | None = None

    def start(self, ctx: ComponentContext) -> None:
        opts = ctx.options
        agent_file = ctx.project_dir / str(opts.get("agent", "agent.asl"))
        if not agent_file.is_file():
            raise ConfigError("agent file not found", file=str(agent_file), key="agent")
        endpoints = BusEndpoints.from_dict(ctx.bus)
        publisher: Publisher = ctx.publisher
        self._tx = ReliableSender(endpoints, src=ctx.name, inc=ctx.incarnation,
                                  channel=ACTION_CHANNEL)
        beliefs = opts.get("beliefs", [])
        if not isinstance(beliefs, list) or not all(isinstance(b, str) for b in beliefs):
            raise ConfigError("must be a list of belief strings", key="beliefs")
        self._port = bus_port(ctx)
        self._data = DataLayerClient(self._port)
        heartbeat = Heartbeat(component=ctx.name, pid=os.getpid())
        period = float(opts.get("heartbeat", 0.5))
        last = [0.0]

        def tick() -> None:
            now = reasoner.agent.clock()
            if now - last[0] >= period:
                last[0] = now
                publisher.publish(heartbeat)

        tx = self._tx
        try:
            reasoner = Reasoner(
                agent_file, name=ctx.name, send_request=lambda r: tx.send(r),
                send_control=lambda c: publisher.publish(c),
                data_call=self._data.call,
                beliefs=list(beliefs), lease=float(opts.get("lease", 10.0)),
                query_timeout=float(opts.get("query_timeout", 5.0)), on_tick=tick,
                tick=min(period, 0.5))
        except AslSyntaxError as exc:
            raise ConfigError(str(exc), file=str(agent_file), key="agent") from exc
        reasoner.snapshot_sink = lambda snap: publisher.publish(_mind(ctx.name, snap))
        self.reasoner = reasoner
        publisher.publish(heartbeat)  # announce this incarnation before anything else
        self._sub = Subscriber(endpoints, prefixes=["percept", "action.status", "sup.",
                                                    "robot.", "ctl.mind"])
        self._sub.start(reasoner.on_message)
        reasoner.start()
        log.info("%s: reasoning on %s (incarnation %d)", ctx.name, agent_file, ctx.incarnation)

    def stop(self) -> None:
        if self._sub is not None:
            self._sub.close()
        if self.reasoner is not None:
            self.reasoner.stop()
        if self._tx is not None:
            self._tx.close()
        if self._data is not None:
            self._data.close()
        if self._port is not None:
            self._port.close()


def _mind(name: str, snap: dict[str, Any]) -> MindSnapshot:
    return MindSnapshot(agent=name, beliefs=[str(b) for b in snap.get("beliefs", [])],
                        intentions=list(snap.get("intentions", [])),
                        events=[_event_text(e) for e in snap.get("events", [])])


def _event_text(event: Any) -> str:
    """A pending event as one line: its trigger, and the intention that posted it."""
    if not isinstance(event, dict):
        return str(event)
    owner = event.get("intention")
    return f"{event.get('trigger', '?')}" + (f"  (intention #{owner})" if owner is not None
                                            else "")
