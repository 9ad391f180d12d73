"""The Reasoner component: the project's AgentSpeak agent on the bus (paper IV-D).

- `percept` messages become percepts (`source(percept)`), add or remove, once they pass
  `mrss.actors.percept_guard` (ground, bounded, finite, no sender-set `source(...)`):
  others are refused, counted (`Reasoner.rejections`) and logged at a limited rate; they arrive on
  the reliable channel "percept" (acknowledged after the percept ledger has them) and,
  from best-effort senders, on the plain `percept` topic; a message heard on both is
  taken once (by envelope id). The ledger (`PerceptLedger`) is asserted again by every
  new incarnation, so the agent re-derives its goals after a restart;
  supervision's `sup.quarantine` / `sup.release` and `robot.<id>.state` availability
  become `robot_unavailable(R)` percepts;
- environment actions leave on the reliable `action` channel and block their intention
  until a terminal `action.status`; waiting actions are reconciled with the RCL, and a
  restarted reasoner adopts what its predecessor left running (see `ReasonerHost`);
- a heartbeat with this incarnation goes out every `heartbeat` seconds: the RCL cancels
  the actions of an incarnation that is gone, so no robot works for a dead intention;
- `ctl.mind` (any target, or this reasoner's name) publishes a `mind.<name>` snapshot.

Options (the component's table in project.toml): `agent` (file, default `agent.asl`),
`beliefs` (extra initial beliefs), `lease` (seconds the RCL may be silent while actions
wait, default 10), `heartbeat` (seconds, default 0.5), `query_timeout` (seconds),
`reconcile` (seconds between status queries while actions wait, default 1),
`adopt_wait` (seconds a restarted reasoner waits for the RCL's inventory, default 3).
"""

from __future__ import annotations

import functools
import logging
import os
import sqlite3
import threading
from collections import OrderedDict
from collections.abc import Callable
from pathlib import Path
from typing import Any, ClassVar

from mrss.actors.percept_guard import checked_literal
from mrss.actors.percept_ledger import PerceptLedger
from mrss.actors.reasoner_agents import ActionRouter, AgentHost, AgentSpec, agent_specs
from mrss.actors.reasoner_host import ReasonerHost
from mrss.agentspeak import Agent, AslSyntaxError
from mrss.agentspeak.agent import read_program
from mrss.agentspeak.loadcheck import load_problems, one_line
from mrss.agentspeak.society import Society
from mrss.bus import (
    BusEndpoints,
    Incarnations,
    NotHandled,
    Publisher,
    ReliableReceiver,
    ReliableSender,
    Subscriber,
)
from mrss.edge.component import ZmqBusPort, bus_port
from mrss.edge.datalayer_client import DataLayerClient
from mrss.edge.rejections import RejectionLog
from mrss.edge.validation import Rejected
from mrss.errors import ConfigError, MrssError
from mrss.messages import (
    ActionControl,
    ActionInventory,
    ActionQuery,
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
from mrss.options import Check, Option
from mrss.supervision.component import Component, ComponentContext

log = logging.getLogger("mrss.reasoner")

ACTION_CHANNEL = "action"
PERCEPT_CHANNEL = "percept"
RCL_PREFIX = "rcl"
SEEN_IDS = 8192  # envelope ids remembered to take a percept heard twice once


def unavailable_percept(robot: str) -> str:
    return f"robot_unavailable({robot})"


class Reasoner:
    """The agent, its host and its loop thread; bus-agnostic (tests drive it directly)."""

    def __init__(self, agent_file: Path | None, *, name: str,
                 send_request: Callable[[ActionRequest], object],
                 send_control: Callable[[ActionControl], object],
                 data_call: Any = None, beliefs: list[str] | None = None,
                 lease: float = 10.0, query_timeout: float = 5.0,
                 on_tick: Callable[[], None] | None = None, tick: float = 0.5,
                 send_query: Callable[[ActionQuery], object] | None = None,
                 reconcile: float = 1.0, adopt_wait: float = 3.0,
                 ledger: PerceptLedger | None = None,
                 agents: list[AgentSpec] | None = None, base: Path | None = None) -> None:
        """One agent from `agent_file` named `name`, or, with `agents`, several (their
        files relative to `base`) in a society (see `reasoner_agents`)."""
        self.host = ReasonerHost(send_request, send_control, data_call, lease=lease,
                                 query_timeout=query_timeout, send_query=send_query,
                                 reconcile=reconcile, adopt_wait=adopt_wait)
        self.society: Society | None = None
        if agents:
            self.society = Society(out=lambda line: log.info("%s: %s", name, line))
            router = ActionRouter()
            self.host.agent = router
            for spec in agents:
                view = AgentHost(self.host, router)
                agent = Agent.from_file((base or Path.cwd()) / spec.file, host=view,
                                        name=spec.name, beliefs=spec.beliefs,
                                        actions=self.society.registry,
                                        out=functools.partial(self._print_of, spec.name))
                view.agent = agent
                self.society.join(agent)
            self.agents = list(self.society.agents.values())
            self.agent = self.agents[0]
        else:
            if agent_file is None:
                raise ValueError("Reasoner needs an agent file or agents")
            self.agent = Agent.from_file(agent_file, host=self.host, name=name,
                                         beliefs=beliefs or [], out=self._print)
            self.host.agent = self.agent
            self.agents = [self.agent]
        self.ledger = ledger
        self.rejections = RejectionLog(log, "percept")
        self._seen: OrderedDict[str, None] = OrderedDict()
        self._seen_lock = threading.Lock()
        if ledger is not None:
            if self.society is None:  # with several agents the bus's word alone counts
                self.agent.on_percept_gone = ledger.remove
            standing = ledger.standing()
            for literal in standing:  # what the previous incarnation perceived
                for agent in self.agents:
                    agent.add_percept(literal)
            if standing:
                log.info("%s: %d standing percept(s) asserted again", name, len(standing))
        self.name = name
        self._on_tick = on_tick
        self._tick = tick
        self._stop = threading.Event()
        self._thread = threading.Thread(target=self._loop, name=f"{name}-loop", daemon=True)
        self._snapshot_wanted = threading.Event()
        self.snapshot_sink: Callable[[dict[str, Any]], object] | None = None

    def _print(self, line: str) -> None:
        log.info("%s: %s", self.name, line)

    def _print_of(self, agent: str, line: str) -> None:
        log.info("%s: [%s] %s", self.name, agent, line)

    def mind_name(self, snapshot: dict[str, Any]) -> str:
        """The name a snapshot is published under: the component's, or with several
        agents `component.agent`."""
        if self.society is None:
            return self.name
        return f"{self.name}.{snapshot.get('agent', '?')}"

    def start(self) -> None:
        self._thread.start()

    def stop(self) -> None:
        self._stop.set()
        self.agent.wake()
        self._thread.join(timeout=5)
        self.host.close()
        self.rejections.flush()

    def request_snapshot(self) -> None:
        self._snapshot_wanted.set()
        self.agent.wake()

    def _loop(self) -> None:
        agents = self.agents
        society = self.society
        wait: Callable[[float], object] = agents[0].wait_for_work if society is None \
            else society.wait_for_work
        while not self._stop.is_set():
            timeout = self._tick
            for agent in agents:
                deadline = agent.next_deadline()
                if deadline is not None:
                    timeout = max(0.0, min(timeout, deadline - agent.clock()))
            wait(timeout)
            try:
                if society is None:
                    agents[0].run_until_idle(max_cycles=10_000)
                else:  # one cycle of each agent in turn
                    society.run_cycles(max_rounds=10_000)
            except Exception:  # the agent must keep serving whatever one cycle did
                log.exception("%s: reasoning cycle failed", self.name)
            self.host.reconcile()
            self.host.check_lease()
            if self._on_tick is not None:
                self._on_tick()
            if self._snapshot_wanted.is_set() and self.snapshot_sink is not None:
                self._snapshot_wanted.clear()
                for agent in agents:
                    self.snapshot_sink(agent.snapshot(self.host.action_uuid))

    # ------------------------------------------------------------ inputs
    def on_message(self, env: Envelope) -> None:
        """Route one bus message to the agent or the host; bad data is logged, never fatal."""
        body = env.body
        try:
            if isinstance(body, Percept):
                self._perceive(body, env.id, env.src)
            elif isinstance(body, ActionStatus):
                self.host.on_status(body, env.inc)
            elif isinstance(body, ActionInventory):
                self.host.on_inventory(body)
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

    def _perceive(self, percept: Percept, msg_id: str, sender: str = "?") -> None:
        """Checked (a refused percept is counted and logged, and taken as handled), then
        ledger first (the sender may stop repeating it), then the agent. A ledger that
        cannot be written leaves the percept unacknowledged (NotHandled): it comes again."""
        with self._seen_lock:
            if msg_id in self._seen:
                return
        try:
            literal = checked_literal(percept.literal)
        except Rejected as exc:
            self.rejections.reject(sender, exc.reason, exc.detail)
            return
        if self.ledger is not None:
            try:
                if percept.op == "add":
                    self.ledger.add(percept.literal, literal)
                else:
                    self.ledger.remove(literal)
            except (sqlite3.Error, OSError) as exc:
                raise NotHandled(f"the percept ledger cannot be written: {exc}") from exc
        with self._seen_lock:
            if msg_id in self._seen:
                return
            self._seen[msg_id] = None
            if len(self._seen) > SEEN_IDS:
                self._seen.popitem(last=False)
        for agent in self.agents:  # each agent perceives every percept
            if percept.op == "add":
                agent.add_percept(literal)
            else:
                agent.remove_percept(literal)

    def _on_sup(self, event: SupEvent) -> None:
        robot = event.detail.get("robot")
        if not isinstance(robot, str) or not robot:
            return
        if event.event == "quarantine":
            self._set_unavailable(robot, True)
        elif event.event == "release":
            self._set_unavailable(robot, False)

    def _set_unavailable(self, robot: str, unavailable: bool) -> None:
        try:  # the robot name comes from the bus: `X` or `r(X)` is no robot
            literal = checked_literal(unavailable_percept(robot))
        except Rejected as exc:
            self.rejections.reject(robot, exc.reason, exc.detail)
            return
        for agent in self.agents:
            if unavailable:
                agent.add_percept(literal)
            else:
                agent.remove_percept(literal)


class ReasonerComponent(Component):
    """The reasoner as an OS process under the root supervisor."""

    #: The options this component reads (`mrss check` validates them; docs/config.md).
    OPTIONS: ClassVar[tuple[Option, ...]] = (
        Option("agent", str, "agent.asl", "the AgentSpeak program", Check.PROJECT_FILE),
        Option("beliefs", list, [], "extra initial beliefs, as literal strings"),
        Option("agents", list, None, "several agents instead of `agent`, as .mas2j lists "
               "them: [{ name = \"a\", file = \"a.asl\", beliefs = [...] }, ...]"),
        Option("heartbeat", float, 0.5, "seconds between heartbeats", Check.POSITIVE),
        Option("ledger", str, None, "percept ledger path (default in the run folder)"),
        Option("lease", float, 10.0, "seconds a waiting action survives a silent RCL",
               Check.POSITIVE),
        Option("query_timeout", float, 5.0, "seconds per data layer query", Check.POSITIVE),
        Option("reconcile", float, 1.0, "seconds between reconciliations after a restart",
               Check.POSITIVE),
        Option("adopt_wait", float, 3.0, "seconds to wait for open actions to be adopted",
               Check.NON_NEGATIVE),
    )

    def __init__(self) -> None:
        self.reasoner: Reasoner | None = None
        self._tx: ReliableSender | None = None
        self._sub: Subscriber | None = None
        self._rx: ReliableReceiver | None = None
        self._data: DataLayerClient | None = None
        self._port: ZmqBusPort | None = None
        self._ledger: PerceptLedger | None = None

    def start(self, ctx: ComponentContext) -> None:
        opts = ctx.options
        specs = agent_specs(opts, ctx.project_dir)
        agent_file = ctx.project_dir / str(opts.get("agent", "agent.asl"))
        beliefs = opts.get("beliefs", [])
        if specs is None:
            if not agent_file.is_file():
                raise ConfigError("agent file not found", file=str(agent_file), key="agent")
            if not isinstance(beliefs, list) or not all(isinstance(b, str) for b in beliefs):
                raise ConfigError("must be a list of belief strings", key="beliefs")
            refuse_unloadable(agent_file, beliefs)  # before anything is started
        else:
            for spec in specs:
                refuse_unloadable(ctx.project_dir / spec.file, spec.beliefs, society=True,
                                  key="agents")
        endpoints = BusEndpoints.from_dict(ctx.bus)
        publisher: Publisher = ctx.publisher
        self._tx = ReliableSender(endpoints, src=ctx.name, inc=ctx.incarnation,
                                  channel=ACTION_CHANNEL)
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
        restarted = ctx.incarnation > 1  # within this run: mission state is taken back
        self._ledger = PerceptLedger(
            Path(opts.get("ledger") or ctx.run_dir / f"{ctx.name}-percepts.sqlite3"),
            fresh=not restarted)
        try:
            reasoner = Reasoner(
                agent_file if specs is None else None, name=ctx.name, agents=specs,
                base=ctx.project_dir, send_request=lambda r: tx.send(r),
                send_control=lambda c: tx.send(c),  # in order with its requests, resent
                data_call=self._data.call,
                beliefs=list(beliefs), lease=float(opts.get("lease", 10.0)),
                query_timeout=float(opts.get("query_timeout", 5.0)), on_tick=tick,
                tick=min(period, 0.5), send_query=lambda q: publisher.publish(q),
                reconcile=float(opts.get("reconcile", 1.0)),
                adopt_wait=float(opts.get("adopt_wait", 3.0)), ledger=self._ledger)
        except AslSyntaxError as exc:
            raise ConfigError(str(exc), file=str(agent_file),
                              key="agent" if specs is None else "agents") from exc
        reasoner.snapshot_sink = lambda snap: publisher.publish(
            _mind(reasoner.mind_name(snap), snap))
        self.reasoner = reasoner
        publisher.publish(heartbeat)  # announce this incarnation before anything else
        if restarted:
            reasoner.host.expect_inventory(ctx.name, ctx.incarnation)
        live = Incarnations(ctx.name)  # one filter of dead incarnations for both receivers
        self._sub = Subscriber(endpoints, prefixes=["percept", "action.status",
                                                    "action.inventory", "sup.", "robot.",
                                                    "ctl.mind"], incarnations=live,
                              skip=_robot_data)
        self._sub.start(reasoner.on_message)
        self._rx = ReliableReceiver(endpoints, src=ctx.name, inc=ctx.incarnation,
                                    channel=PERCEPT_CHANNEL, handler=reasoner.on_message,
                                    incarnations=live)
        reasoner.start()
        log.info("%s: reasoning on %s (incarnation %d)", ctx.name,
                 agent_file if specs is None else ", ".join(f"{s.name} ({s.file})"
                                                             for s in specs),
                 ctx.incarnation)

    def stop(self) -> None:
        for closable in (self._rx, self._sub):
            if closable is not None:
                closable.close()
        if self.reasoner is not None:
            self.reasoner.stop()
        if self._ledger is not None:
            self._ledger.close()
        if self._tx is not None:
            self._tx.close()
        if self._data is not None:
            self._data.close()
        if self._port is not None:
            self._port.close()


def _robot_data(topic: bytes) -> bool:
    """A robot's telemetry (`robot.<id>.data`): the reasoner takes a robot's state from
    the `robot.` topics, not the data stream (1,000 messages a second at 100 robots)."""
    return topic.startswith(b"robot.") and topic.endswith(b".data")


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


def refuse_unloadable(agent_file: Path, beliefs: list[str], *, society: bool = False,
                      key: str = "agent") -> None:
    """ConfigError (one line, `file:line:col: message`) unless the program and the
    initial beliefs load: the check `mrss check` makes, so a bad program is refused at
    start and not restarted (docs/supervision.md) instead of crashing in a loop.
    `society`: the program runs among others (`.send` and the like are known)."""
    try:
        text = read_program(agent_file)
    except OSError as exc:
        raise ConfigError(f"cannot read: {exc.strerror or exc}", file=str(agent_file),
                          key=key) from None
    except AslSyntaxError as exc:  # not UTF-8
        raise ConfigError(one_line(exc.problems), key=key) from None
    problems = load_problems(text, str(agent_file), beliefs, society=society)
    if problems:
        raise ConfigError(one_line(problems), key=key if problems[0].file != "beliefs"
                          or society else "beliefs")
