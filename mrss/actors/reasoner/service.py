"""The Reasoner component: the project's AgentSpeak agent on the bus (paper IV-D).

The component runs a `Reasoner` (mrss.actors.reasoner.core: percepts in, environment
actions out, the agent's loop) as an OS process under the root supervisor and wires it
to the bus:

- a program (or initial beliefs) that does not load is refused at start
  (`refuse_unloadable`, a ConfigError: not restarted);
- percepts arrive on the reliable channel "percept" and on the plain `percept` topic,
  statuses, inventories, supervision events and robot states on their topics (a robot's
  `robot.<id>.data` stream is skipped); environment actions and controls leave on the
  reliable `action` channel;
- a heartbeat with this incarnation goes out every `heartbeat` seconds: the RCL cancels
  the actions of an incarnation that is gone, so no robot works for a dead intention;
- `ctl.mind` (any target, or this reasoner's name) publishes a `mind.<name>` snapshot;
- a goal an agent gives up for good is published as `agent.gave_up.<agent>`
  (`GoalGaveUp`: goal, reason, last cause), the operator's alert;
- the agent's questions to the operator (`.ask_operator`) are journaled
  (`<run_dir>/<name>-questions.sqlite3`, kept across restarts within a run) and published
  on `question.<agent>`; answers come on `question.answer`, each replied to on
  `question.reply`; `ctl.questions` publishes the pending ones again.

Options (the component's table in project.toml): `agent` (file, default `agent.asl`),
`beliefs` (extra initial beliefs), `lease` (seconds the RCL may be silent while actions
wait, default 10), `heartbeat` (seconds, default 0.5), `query_timeout` (seconds),
`reconcile` (seconds between status queries while actions wait, default 1),
`adopt_wait` (seconds a restarted reasoner waits for the RCL's inventory, default 3).
"""

from __future__ import annotations

import logging
import os
from pathlib import Path
from typing import Any, ClassVar

from mrss.actors.reasoner.agents import agent_specs
from mrss.actors.reasoner.core import Reasoner
from mrss.actors.reasoner.percept_ledger import PerceptLedger
from mrss.actors.reasoner.question_journal import QuestionJournal
from mrss.agentspeak import AslSyntaxError
from mrss.agentspeak.agent import read_program
from mrss.agentspeak.loadcheck import load_problems, one_line
from mrss.bus import (
    BusEndpoints,
    Incarnations,
    Publisher,
    ReliableReceiver,
    ReliableSender,
    Subscriber,
)
from mrss.errors import ConfigError
from mrss.messages import Heartbeat, MindSnapshot
from mrss.options import Check, Option, OptionValues
from mrss.runtime.busport import ZmqBusPort, bus_port
from mrss.runtime.component import Component, ComponentContext
from mrss.runtime.datalayer_client import DataLayerClient
from mrss.runtime.operator_guard import OperatorGuard, answer_guard, percept_guard

log = logging.getLogger("mrss.reasoner")

ACTION_CHANNEL = "action"
PERCEPT_CHANNEL = "percept"


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
        self._questions: QuestionJournal | None = None

    def start(self, ctx: ComponentContext) -> None:
        opts = OptionValues(self.OPTIONS, ctx.options)
        specs = agent_specs(ctx.options, ctx.project_dir)
        agent_file = ctx.project_dir / opts.text("agent")
        beliefs = opts["beliefs"]
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
        period = opts.number("heartbeat")
        last = [0.0]

        def tick() -> None:
            now = reasoner.agent.clock()
            if now - last[0] >= period:
                last[0] = now
                publisher.publish(heartbeat)

        tx = self._tx
        restarted = ctx.incarnation > 1  # within this run: mission state is taken back
        self._ledger = PerceptLedger(
            Path(opts["ledger"] or ctx.run_dir / f"{ctx.name}-percepts.sqlite3"),
            fresh=not restarted)
        self._questions = QuestionJournal(ctx.run_dir / f"{ctx.name}-questions.sqlite3",
                                          fresh=not restarted)
        try:
            reasoner = Reasoner(
                agent_file if specs is None else None, name=ctx.name, agents=specs,
                base=ctx.project_dir, send_request=lambda r: tx.send(r),
                send_control=lambda c: tx.send(c),  # in order with its requests, resent
                data_call=self._data.call,
                beliefs=list(beliefs), lease=opts.number("lease"),
                query_timeout=opts.number("query_timeout"), on_tick=tick,
                tick=min(period, 0.5), send_query=lambda q: publisher.publish(q),
                reconcile=opts.number("reconcile"),
                adopt_wait=opts.number("adopt_wait"), ledger=self._ledger,
                send_alert=publisher.publish, questions=self._questions,
                send_question=publisher.publish)
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
                                                    "ctl.mind", "ctl.questions",
                                                    "question.answer"], incarnations=live,
                              skip=_robot_data)
        # A robot's state is taken only from the component that owns its link.
        from mrss.edge.robot_owners import RobotOwners

        owners = RobotOwners.of_project(ctx.project_dir, proven=bool(endpoints.key))
        # An operator's percept (from no supervised component) needs a credential whose
        # role may send percepts, once the project has users (mrss.runtime.operator_guard)
        operators = OperatorGuard(ctx.project_dir, log)
        self._sub.start(answer_guard(operators, percept_guard(
            operators, owners.guard(reasoner.on_message)), publisher.publish))
        self._rx = ReliableReceiver(endpoints, src=ctx.name, inc=ctx.incarnation,
                                    channel=PERCEPT_CHANNEL,
                                    handler=percept_guard(operators, reasoner.on_message),
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
        if self._questions is not None:
            self._questions.close()
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
