"""The RCL as a bus component: RclCore behind the reliable action channel and the bus.

- `action.request` arrives on the reliable channel "action" (ReliableReceiver: repeated
  until acknowledged, handled once per message id; RclCore de-duplicates by uuid on top);
- `action.control` (goal management) and `ctl.teleop` (Command, target = robot,
  args {"on": bool}) arrive on a Subscriber; so do `sup.heartbeat.*`, whose envelope
  incarnation tells the RCL that a requester restarted (its orphans wait `adopt_grace`
  seconds for the new incarnation to adopt them, then are cancelled), and
  `action.query` (reconciliation: statuses from the journal, and the inventory of a
  restarted requester's predecessors);
- `ctl.decommission` / `ctl.recommission` (Command, target = robot, from the operator)
- `ctl.stand_down` / `ctl.stand_down_lift` (Command, target = its id: mrss.actors.rcl.stand_down)
  take a robot out of service (its tasks addressed to a role go to others) and back;
- at start, a robot whose link is not up yet is unavailable until its link first
  reports up, and lost past the link's timeout without a report (checked on every
  heartbeat tick): `RobotAvailability.await_first_reports`; on every tick, too, the
  tasks addressed to a role of a robot whose battery is critical go to others
  (`Reallocation.battery_check`);
- `ctl.snapshot` (Command, from an observer such as the dashboard) is answered with
  every robot's state and every open action's status (`repeat`): `RclCore.snapshot`;
- `action.status` and `robot.<id>.state` leave through the component's Publisher,
  each action status after its journal commit; `sup.*` events of the robot supervisor
  too; and a `sup.heartbeat.<name>` every `heartbeat` seconds while the robot
  supervisor lives, which renews the reasoner's lease on its waiting actions; with it,
  the progress skills recorded since the last one, as `repeat` statuses at most once
  every `progress_every` seconds per action (`mrss.actors.rcl.progress_feed`).

Options (project.toml, the component's table): `layer` ("rcl.py:ClassName" relative to
the project folder, default: the RobotCommLayer subclass in rcl.py), `robots` (robot id
-> link options for `connect_robot`), `journal` (path; default <run_dir>/<name>-journal
.sqlite3), `durable` (fsync every transition), and the robot supervisor's
`max_robot_restarts`, `restart_period`, `probation`; `adopt_grace` (seconds a dead
requester's running actions wait for adoption, default 10) and `adopt_grace_suspended`
(suspended ones, default 120). The first incarnation of a run
fails actions a previous run left in a kept journal; later ones resume them.
"""

from __future__ import annotations

import logging
import os
import sqlite3
import sys
import threading
import time
from pathlib import Path
from typing import Any, ClassVar

from mrss.actors.rcl.allocation.evaluators import BidRanking, Evaluator
from mrss.actors.rcl.allocation.profile import RobotProfile, split_table
from mrss.actors.rcl.availability import silence_timeout
from mrss.actors.rcl.core import RclCore
from mrss.actors.rcl.journal import ActionJournal, Requester
from mrss.actors.rcl.layer import RobotCommLayer
from mrss.actors.rcl.options import RCL_OPTIONS
from mrss.actors.rcl.stand_down import LIFT, STAND_DOWN
from mrss.auth.roles import CommandKind
from mrss.bus import BusEndpoints, Incarnations, NotHandled, ReliableReceiver, Subscriber
from mrss.errors import ConfigError, MrssError
from mrss.links.base import RobotLink
from mrss.messages import (
    ActionControl,
    ActionQuery,
    ActionRequest,
    Command,
    Envelope,
    Heartbeat,
    SupEvent,
)
from mrss.options import Option, OptionValues
from mrss.runtime.busport import ZmqBusPort, bus_port
from mrss.runtime.component import Component, ComponentContext
from mrss.runtime.datalayer_client import DataLayerClient
from mrss.runtime.loader import load_project_class
from mrss.runtime.operator_guard import OperatorGuard
from mrss.supervision.nodes import NODE_DOWN, NODE_UP

log = logging.getLogger("mrss.rcl")

ACTION_CHANNEL = "action"


def load_layer(project_dir: Path, spec: str = "") -> RobotCommLayer:
    """Instantiate the project's RobotCommLayer from "file.py:Class" (default rcl.py)."""
    file_name, _, class_name = (spec or "rcl.py").partition(":")
    if str(project_dir) not in sys.path:  # rcl.py may import its sibling skills.py
        sys.path.insert(0, str(project_dir))
    cls = load_project_class(project_dir, file_name, RobotCommLayer,
                             class_name=class_name or None, key="layer")
    layer: RobotCommLayer = cls()
    return layer


class RclService(Component):
    """The Robot Communication Layer component (one OS process under the supervisor).

    project.toml: `[components.rcl] kind = "rcl"`.
    """

    #: The options this component reads (`mrss check` validates them; docs/config.md).
    OPTIONS: ClassVar[tuple[Option, ...]] = RCL_OPTIONS

    def __init__(self) -> None:
        self.core: RclCore | None = None
        self.journal: ActionJournal | None = None
        self.layer: RobotCommLayer | None = None
        self.links: dict[str, Any] = {}
        self._rx: ReliableReceiver | None = None
        self._sub: Subscriber | None = None
        self.incarnations = Incarnations("rcl")  # replaced at start (named for the component)
        self._name = "rcl"
        self._stop = threading.Event()
        self._beat: threading.Thread | None = None
        self._port: ZmqBusPort | None = None
        self._data: DataLayerClient | None = None
        self._compaction = (86400.0, 1000, 600.0)  # keep seconds, keep last, period

    def start(self, ctx: ComponentContext) -> None:
        opts = OptionValues(self.OPTIONS, ctx.options)
        self._name = ctx.name
        self.layer = load_layer(ctx.project_dir, opts.text("layer"))
        publisher = ctx.publisher
        self._port = bus_port(ctx)
        self._data = DataLayerClient(self._port)
        self.layer.bind_runtime(project_dir=ctx.project_dir, run_dir=ctx.run_dir,
                                publish=publisher.publish, data_call=self._data.call,
                                gather=publisher.gathering)
        robots = opts["robots"]
        if not isinstance(robots, dict) or not robots:
            raise ConfigError("the RCL needs a table of robots", key="robots")
        # `node`: the node a robot is reached through (mrss.config.nodes), the RCL's, not the link's
        tables = {str(r): dict(o) if isinstance(o, dict) else {} for r, o in robots.items()}
        robot_nodes = {r: str(t.pop("node")) for r, t in tables.items() if "node" in t}
        # what a robot can do, for tasks addressed to a role: the RCL's keys too
        profiles = {}
        for r in list(tables):
            mine, tables[r] = split_table(tables[r])
            profiles[r] = RobotProfile.read(r, mine, section=f"robots.{r}")
        self.links = {r: self.layer.connect_robot(r, t) for r, t in tables.items()}
        journal_path = Path(opts["journal"] or ctx.run_dir / f"{ctx.name}-journal.sqlite3")
        self.journal = ActionJournal(journal_path, durable=opts.flag("durable"))
        if not publisher.wait_connected(5.0):  # else the restored statuses could be lost
            log.warning("%s: the bus proxy has not greeted the publisher yet", ctx.name)
        endpoints = BusEndpoints.from_dict(ctx.bus)
        # Subscribed before the restored actions are announced, so that the answers to
        # those statuses (a cancel, a suspend) are heard: they wait in the socket until
        # the core has started. Ready also means controls are heard.
        # One filter of dead incarnations for both receivers; after a restart of the RCL
        # it knows from the journal which requester incarnations are gone.
        self.operators = OperatorGuard(ctx.project_dir, log)  # who may command the RCL
        self.incarnations = Incarnations(ctx.name)
        if ctx.incarnation > 1:
            for src, inc in self.journal.incarnations().items():
                self.incarnations.learn(src, inc)
        self._sub = Subscriber(endpoints, prefixes=["action.control", "action.query",
                                                    "ctl.teleop", "ctl.snapshot",
                                                    "ctl.decommission", "ctl.recommission",
                                                    "ctl.stand_down",
                                                    "sup.heartbeat.", "sup.node_"],
                               incarnations=self.incarnations)
        if not self._sub.wait_connected(5.0):
            log.warning("%s: control subscription not confirmed by the proxy yet", ctx.name)
        self.core = RclCore(self.layer, self.journal, publisher.publish, self.links,
                            max_robot_restarts=opts.whole("max_robot_restarts"),
                            restart_period=opts.number("restart_period"),
                            probation=opts.number("probation"),
                            adopt_grace=opts.number("adopt_grace"),
                            adopt_grace_suspended=opts.number("adopt_grace_suspended"),
                            preempted_timeout=opts.number("preempted_timeout"),
                            progress_every=opts.number("progress_every"),
                            profiles=profiles,
                            ranking=BidRanking(self.layer.bid_score
                                               or Evaluator(opts.text("evaluator"))))
        self.core.availability.robot_nodes = robot_nodes
        if "bid_timeout" in ctx.options:
            log.warning("%s: bid_timeout is no longer used (an award asks no robot actor to "
                        "confirm its bid); remove it from the project", ctx.name)
        # before the links' states are bound (those reported already are replayed): a
        # robot is unavailable until its link first reports up
        self.core.availability.await_first_reports(
            {r: silence_timeout(link) for r, link in self.links.items()
             if isinstance(link, RobotLink) and not link.up}, time.monotonic())
        self.layer.bind_runtime(link_state=self.core.availability.link_state)
        self._compaction = (opts.number("journal_keep_seconds"),
                            opts.whole("journal_keep_last"),
                            opts.number("journal_compact_period"))
        self._compact()
        self.core.start(new_run=ctx.incarnation <= 1)
        self._sub.start(self._on_message)
        self._rx = ReliableReceiver(endpoints, src=ctx.name, inc=ctx.incarnation,
                                    channel=ACTION_CHANNEL, handler=self._on_request,
                                    incarnations=self.incarnations)
        period = opts.number("heartbeat")
        self._beat = threading.Thread(target=self._heartbeat, args=(publisher, period),
                                      name=f"{ctx.name}-heartbeat", daemon=True)
        self._beat.start()
        log.info("%s: ready with robots %s, journal %s", ctx.name, sorted(self.links),
                 journal_path)

    def healthy(self) -> bool:
        """Alive while the robot supervisor is (heartbeats stop otherwise)."""
        robots = self.core.robots if self.core is not None else None
        return robots is not None and robots.is_alive()

    def _compact(self) -> None:
        """Compact the journal (ActionJournal.compact); a failure is logged, not fatal."""
        keep_seconds, keep_last, _ = self._compaction
        if self.core is not None:
            try:
                self.core.compact_journal(keep_seconds, keep_last)
            except Exception as exc:
                log.error("journal compaction failed: %r", exc)

    def _heartbeat(self, publisher: Any, period: float) -> None:
        beat = Heartbeat(component=self._name, pid=os.getpid())
        next_compaction = time.monotonic() + self._compaction[2]
        while True:
            if self.healthy():
                try:
                    publisher.publish(beat)
                    if self.core is not None:
                        self.core.requesters.cancel_orphans()
                        self.core.observers.publish_progress()
                except Exception as exc:
                    log.error("heartbeat not published: %r", exc)
            if self.core is not None:
                try:
                    self.core.availability.first_reports_due(time.monotonic())
                    self.core.check_batteries()
                except Exception as exc:  # the next tick tries again
                    log.error("robot checks failed: %r", exc)
            if time.monotonic() >= next_compaction:
                next_compaction = time.monotonic() + self._compaction[2]
                self._compact()
            if self._stop.wait(period):
                return

    def stop(self) -> None:
        self._stop.set()
        if self._beat is not None:
            self._beat.join(timeout=5)
        for closable in (self._rx, self._sub, self._data, self._port):
            if closable is not None:
                closable.close()
        if self.core is not None:
            self.core.stop()
        if self.journal is not None:
            self.journal.close()
        if self.layer is not None:
            for robot, link in self.links.items():
                try:
                    self.layer.disconnect_robot(robot, link)
                except Exception as exc:
                    log.error("disconnecting %s failed: %r", robot, exc)

    def _on_request(self, env: Envelope) -> None:
        """The reliable action channel: requests, and the agent's goal management in order
        with them. What cannot be journaled now (a full disk) is not acknowledged: the
        reasoner repeats it until it is."""
        core = self.core
        if core is None:
            raise NotHandled("the RCL is not started yet")
        body = env.body
        try:
            if isinstance(body, ActionRequest):
                core.submit(body, Requester(env.src, env.inc))
            elif isinstance(body, ActionControl):
                core.requesters.saw_incarnation(env.src, env.inc)
                core.control(body, env.src)
            else:
                log.warning("dropped a %s on the action channel from %s", env.kind, env.src)
        except (sqlite3.Error, OSError) as exc:
            raise NotHandled(f"the action journal cannot be written: {exc}") from exc
        except MrssError as exc:
            log.warning("dropped %s from %s: %s", env.kind, env.src, exc)

    def _operator_may(self, env: Envelope) -> str | None:
        """An operator's command (a debug action control, teleop, decommission) passes
        the project's roles here, where it is executed (mrss.runtime.operator_guard)."""
        body = env.body
        kind = None
        if isinstance(body, ActionControl):
            kind = CommandKind.ACTION_CONTROL
        elif isinstance(body, Command) and body.command == "teleop":
            kind = CommandKind.TELEOP
        elif isinstance(body, Command) and body.command in ("decommission", "recommission"):
            kind = CommandKind.DECOMMISSION
        elif isinstance(body, Command) and body.command in (STAND_DOWN, LIFT):
            kind = CommandKind.STAND_DOWN
        if kind is None:
            return env.src
        what = (f"{body.command.value} {body.target}" if isinstance(body, ActionControl)
                else f"ctl.{body.command} {body.target}" if isinstance(body, Command) else "")
        verdict = self.operators.check_envelope(env, kind, what)
        return verdict.who if verdict.ok else None

    def _on_message(self, env: Envelope) -> None:
        core = self.core
        if core is None or env.src == self._name:
            return
        body = env.body
        who = self._operator_may(env)  # the operator (or component) it is from; None: refused
        if who is None:
            return
        try:
            if isinstance(body, ActionControl):
                core.requesters.saw_incarnation(env.src, env.inc)
                core.control(body, env.src)
            elif isinstance(body, ActionQuery):
                core.requesters.answer_query(body, Requester(env.src, env.inc))
            elif isinstance(body, Command) and body.command == "teleop":
                on = body.args.get("on")
                if not isinstance(on, bool):
                    raise MrssError(f"teleop command needs args.on true/false, not {on!r}")
                core.availability.set_teleop(body.target, on)
            elif isinstance(body, Command) and body.command in ("decommission",
                                                                "recommission"):
                core.availability.decommission(body.target, body.command == "decommission")
            elif isinstance(body, Command) and body.command in (STAND_DOWN, LIFT):
                core.stand_downs.command(body, who)
            elif isinstance(body, Command) and body.command == "snapshot":
                core.observers.snapshot()
            elif isinstance(body, Heartbeat):
                core.requesters.saw_incarnation(env.src, env.inc)
            elif isinstance(body, SupEvent) and body.event in (NODE_DOWN, NODE_UP):
                core.availability.node_state(body.child, body.event == NODE_UP, body.reason)
        except MrssError as exc:
            log.warning("dropped %s from %s: %s", env.kind, env.src, exc)

