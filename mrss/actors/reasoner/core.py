"""The reasoner's core: the project's agent (or society of agents) on its loop thread.

Bus-agnostic (tests drive it directly; `mrss.actors.reasoner.service.ReasonerComponent` wires
it to the bus), `Reasoner` takes bus messages through `on_message`:

- `percept` messages become percepts (`source(percept)`), add or remove, once they pass
  `mrss.actors.reasoner.percept_guard` (ground, bounded, finite, no sender-set `source(...)`):
  others are refused, counted (`Reasoner.rejections`) and logged at a limited rate; they arrive on
  the reliable channel "percept" (acknowledged after the percept ledger has them) and,
  from best-effort senders, on the plain `percept` topic; a message heard on both, or
  sent again under its id (a redelivery, even to an earlier incarnation: the ledger
  remembers the ids), is taken once. The ledger (`PerceptLedger`) is asserted again by every
  new incarnation, so the agent re-derives its goals after a restart;
  supervision's `sup.quarantine` / `sup.release` and `robot.<id>.state` availability
  become `robot_unavailable(R)` percepts;
- environment actions leave on the reliable `action` channel and block their intention
  until a terminal `action.status`; waiting actions are reconciled with the RCL, and a
  restarted reasoner adopts what its predecessor left running (see `ReasonerHost`);
- `ctl.mind` (any target, or this reasoner's name) asks for a snapshot of each agent,
  handed to `snapshot_sink`;
- a goal an agent gives up for good (its retries used up, no plan, a failure no `-!g`
  plan recovers) goes to `send_alert` as a `GoalGaveUp` (mrss.actors.reasoner.give_up).
"""

from __future__ import annotations

import functools
import logging
import sqlite3
import threading
from collections import OrderedDict
from collections.abc import Callable
from pathlib import Path
from typing import Any

from mrss.actors.reasoner.agents import ActionRouter, AgentHost, AgentSpec
from mrss.actors.reasoner.give_up import GiveUps
from mrss.actors.reasoner.host import ReasonerHost
from mrss.actors.reasoner.percept_guard import checked_literal
from mrss.actors.reasoner.percept_ledger import PerceptLedger
from mrss.actors.reasoner.question_journal import QuestionJournal
from mrss.actors.reasoner.questions import OperatorQuestions
from mrss.agentspeak import Agent
from mrss.agentspeak.society import Society
from mrss.bus import NotHandled
from mrss.edge.rejections import RejectionLog
from mrss.edge.validation import Rejected
from mrss.errors import MrssError
from mrss.messages import (
    ActionControl,
    ActionInventory,
    ActionQuery,
    ActionRequest,
    ActionStatus,
    AnswerReply,
    AnswerVerdict,
    Command,
    Envelope,
    GoalGaveUp,
    Heartbeat,
    OperatorQuestion,
    Percept,
    QuestionAnswer,
    RobotState,
    SupEvent,
    SupEventKind,
)

log = logging.getLogger("mrss.reasoner")

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
                 agents: list[AgentSpec] | None = None, base: Path | None = None,
                 send_alert: Callable[[GoalGaveUp], object] | None = None,
                 questions: QuestionJournal | None = None,
                 send_question: Callable[[OperatorQuestion | AnswerReply], object]
                 | None = None) -> None:
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
        self.host.give_ups = GiveUps(send_alert)
        if questions is not None:
            self.host.questions = OperatorQuestions(
                questions, send_question or (lambda _: None), self._complete_question)
        self.answers = RejectionLog(log, "answer")
        for agent in self.agents:
            agent.on_goal_dropped = self.host.give_ups.dropped_handler(agent.name)
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
        self._send_question = send_question
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
        self.answers.flush()

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
            deadline = agents[0].next_deadline() if society is None else \
                society.next_deadline()  # a society's agents share the clock
            if deadline is not None:
                timeout = max(0.0, min(timeout, deadline - agents[0].clock()))
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
            if self.host.questions is not None:
                self.host.questions.tick()
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
            elif isinstance(body, QuestionAnswer):
                self._on_answer(body, env.src)
            elif (isinstance(body, Command) and body.command == "questions"
                  and self.host.questions is not None):
                self.host.questions.announce()
        except (MrssError, ValueError) as exc:
            log.warning("%s: dropped %s from %s on %s: %s", self.name, env.kind, env.src,
                        env.topic, exc)

    def _complete_question(self, handle: Any, ok: bool, reason: str | None,
                           result: Any) -> None:
        """A question's answer to the agent (through the router with several agents)."""
        self.host.complete(handle, ok, reason, result)

    def _on_answer(self, answer: QuestionAnswer, sender: str) -> None:
        """An operator's answer: taken or refused, the reply goes back to its sender."""
        if self.host.questions is None:
            return
        reply = self.host.questions.answer(answer)
        if reply.verdict is not AnswerVerdict.ACCEPTED:
            self.answers.reject(answer.by or sender, reply.verdict.value, reply.message)
        if self._send_question is not None:
            self._send_question(reply)

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
            try:  # an id taken before (a redelivery, maybe to an earlier incarnation)
                if not self.ledger.take(msg_id, percept.op, percept.literal, literal):
                    return
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
        if event.event is SupEventKind.QUARANTINE:
            self._set_unavailable(robot, True)
        elif event.event is SupEventKind.RELEASE:
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

