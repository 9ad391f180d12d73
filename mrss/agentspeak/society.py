"""Several agents in one process, talking with `.send` and `.broadcast` (Jason's KQML
performatives), run in deterministic round-robin: one reasoning cycle of each agent in
the order given, then again, so a run always prints the same. A round steps only the
agents that may have work (`rounds`): its cost is that of the busy agents, whatever
the number of idle ones.

A message is put in the receiver's inbox and handled at the start of its next cycle:
`tell`/`untell` add/remove the belief annotated `source(sender)`, `achieve` posts the
goal `+!g[source(sender)]`, `unachieve` drops that desire, `tellHow` adds the plan,
`askOne`/`askAll` answer with a `tell` (with a fourth argument the answer is taken
from the receiver's beliefs at once and unified with it; no answer is `false`).
"""

from __future__ import annotations

import enum
import threading
import time
from collections.abc import Callable
from pathlib import Path
from typing import Any

from mrss.agentspeak.agent import Agent, default_registry
from mrss.agentspeak.directory import DF_NAME, Directory
from mrss.agentspeak.formulas import compile_query
from mrss.agentspeak.host import ConsoleHost
from mrss.agentspeak.registry import IAContext, Registry
from mrss.agentspeak.rounds import Rounds
from mrss.agentspeak.termorder import add_annot
from mrss.agentspeak.terms import (
    ADD_BEL,
    DEL_BEL,
    Struct,
    Term,
    Var,
    deref,
    term_str,
    value,
)
from mrss.agentspeak.unify import undo


class Performative(enum.Enum):
    TELL = "tell"
    UNTELL = "untell"
    ACHIEVE = "achieve"
    UNACHIEVE = "unachieve"
    ASK_ONE = "askOne"
    ASK_ALL = "askAll"
    TELL_HOW = "tellHow"


def _source(lit: Struct, sender: str) -> Struct:
    src = Struct("source", (Struct(sender),))
    annots = tuple(a for a in lit.annots if not (type(a) is Struct and a.functor == "source"))
    return Struct(lit.functor, lit.args, add_annot(annots, src), lit.neg)


def _answers(agent: Agent, content: Struct, limit: int | None) -> list[Struct]:
    """The instances of `content` the agent believes (rules included), in order."""
    query = compile_query(content, agent.registry)
    trail = agent.trail
    mark = len(trail)
    found: list[Struct] = []
    for _ in query.solve(agent, []):
        found.append(value(content))  # type: ignore[arg-type]
        if limit is not None and len(found) >= limit:
            break
    undo(trail, mark)
    return found


def receive(agent: Agent, sender: str, perf: Performative, content: Term) -> None:
    """Handle one message in the receiver's cycle."""
    society: Society | None = getattr(agent, "society", None)
    if perf is Performative.TELL_HOW:
        from mrss.agentspeak.stdlib.plans import add_plan
        add_plan(IAContext(agent, None, None, None, ".add_plan"), [content, Struct(sender)])
        return
    if type(content) is not Struct:
        agent.warn(f"message {perf.value} from {sender}: {term_str(content)} is not a literal")
        return
    if perf is Performative.TELL:
        lit = _source(content, sender)
        if agent.bb.add(lit, front=True):
            agent.belief_changed(ADD_BEL, lit, None)
    elif perf is Performative.UNTELL:
        lit = Struct(content.functor, content.args, (Struct("source", (Struct(sender),)),),
                     content.neg)
        if agent.bb.remove(lit):
            agent.belief_changed(DEL_BEL, lit, None)
    elif perf is Performative.ACHIEVE:
        agent.post_goal(_source(content, sender), None)
    elif perf is Performative.UNACHIEVE:
        from mrss.agentspeak.stdlib.control import drop_desire
        drop_desire(IAContext(agent, None, None, None, ".drop_desire"), [content])
    elif society is not None:  # askOne / askAll without a reply variable: tell back
        found = _answers(agent, content, 1 if perf is Performative.ASK_ONE else None)
        for answer in found:
            society.deliver(agent.name, sender, Performative.TELL, answer)


class Society:
    """The agents of one run, by name, in the order they were given."""

    def __init__(self, out: Callable[[str], None] = print) -> None:
        self.agents: dict[str, Agent] = {}
        self.out = out
        self.registry = self._registry()
        self._cond = threading.Condition()  # shared by the agents: input to any wakes
        self.rounds = Rounds(self._cond)  # which agents a round steps
        self.woken = False  # an agent's `wake`: `wait_for_work` returns

    def add(self, path: Path, source: str, name: str) -> Agent:
        prefix = f"[{name}] "
        host = ConsoleHost(lambda s: self.out(prefix + s))
        agent = Agent(source, file=str(path), host=host, name=name, actions=self.registry,
                      out=lambda s: self.out(prefix + s))
        host.agent = agent
        return self.join(agent)

    def join(self, agent: Agent) -> Agent:
        """Make `agent` (built with `actions=self.registry`, before any thread feeds it)
        one of the society."""
        if agent.name in self.agents:
            raise ValueError(f"two agents named {agent.name!r}")
        agent.society = self
        agent._cond = self._cond
        self.agents[agent.name] = agent
        self.rounds.add(agent)
        return agent

    def wait_for_work(self, timeout: float) -> bool:
        """Block until some agent has work (input, a due `.wait`), one is woken, or
        `timeout` seconds pass; True if there is work."""
        rounds = self.rounds
        end = time.monotonic() + timeout
        with self._cond:
            while not rounds.has_work():
                if self.woken:
                    self.woken = False
                    for a in self.agents.values():
                        a._woken = False
                    return False
                remaining = end - time.monotonic()
                deadline = rounds.next_deadline()
                if deadline is not None:
                    remaining = min(remaining, max(deadline - time.monotonic(), 0.0))
                if remaining <= 0:
                    return rounds.has_work()
                self._cond.wait(remaining)
            return True

    def next_deadline(self) -> float | None:
        """The earliest `.wait`/`.at` deadline of an agent with nothing else to do."""
        return self.rounds.next_deadline()

    def run_cycles(self, max_rounds: int | None = None) -> int:
        """Round-robin cycles (one of each agent with work, in order) until none is
        busy; returns the number of rounds in which one was."""
        rounds = 0
        while self.rounds.round():
            rounds += 1
            if max_rounds is not None and rounds >= max_rounds:
                return rounds
        return rounds

    def deliver(self, sender: str, receiver: str, perf: Performative, content: Term) -> bool:
        agent = self.agents.get(receiver)
        if agent is None:
            return False
        agent._put(("msg", sender, perf, value(content)))
        return True

    # ------------------------------------------------------------------ running
    def run(self, max_time: float | None = None) -> bool:
        """Round-robin cycles until every agent is idle (True) or `max_time` passes."""
        start = time.monotonic()
        rounds = self.rounds
        while True:
            if rounds.round():
                if max_time is not None and time.monotonic() - start >= max_time:
                    return False
                continue
            if rounds.idle():
                return True
            waited = time.monotonic() - start
            if max_time is not None and waited >= max_time:
                return False
            self.wait_for_work(1.0 if max_time is None else min(1.0, max_time - waited))

    # ------------------------------------------------------------------ actions
    def _registry(self) -> Registry:
        reg = default_registry().child()
        reg.register(".send", self._send, min_args=3, max_args=4)
        reg.register(".broadcast", self._broadcast, min_args=2, max_args=2)
        reg.register(".all_names", self._all_names, min_args=1, max_args=1)
        self.directory = Directory(
            lambda receiver, lit: self.deliver(DF_NAME, receiver, Performative.TELL, lit))
        self.directory.register(reg)
        return reg

    def _perf(self, ctx: IAContext, t: Term) -> Performative:
        t = deref(t)
        if type(t) is Struct and not t.args:
            for p in Performative:
                if p.value == t.functor:
                    return p
        known = ", ".join(p.value for p in Performative)
        raise ctx.error(f"unknown performative {term_str(t)} (expected one of {known})")

    def _send(self, ctx: IAContext, args: list[Any]) -> bool:
        """`.send(Receiver, Performative, Content)` (Receiver may be a list), and
        `.send(Receiver, askOne|askAll, Content, Answer)`."""
        perf = self._perf(ctx, args[1])
        content = value(args[2])
        if type(content) is Var:
            raise ctx.error("the content is an unbound variable")
        receivers = deref(args[0])
        names = list(receivers) if type(receivers) is tuple else [receivers]
        sender = ctx.runtime.name
        if len(args) == 4:
            if perf not in (Performative.ASK_ONE, Performative.ASK_ALL) or len(names) != 1:
                raise ctx.error("a reply argument needs askOne or askAll and one receiver")
            agent = self._receiver(ctx, names[0])
            if type(content) is not Struct:
                raise ctx.error(f"cannot ask {term_str(content)}: not a literal")
            found = [_source(a, agent.name)
                     for a in _answers(agent, content,
                                       1 if perf is Performative.ASK_ONE else None)]
            if perf is Performative.ASK_ALL:
                return ctx.unify(args[3], tuple(found))
            return ctx.unify(args[3], found[0] if found else Struct("false"))
        for name in names:
            self.deliver(sender, self._receiver(ctx, name).name, perf, content)
        return True

    def _receiver(self, ctx: IAContext, name: Term) -> Agent:
        name = deref(name)
        text = name.functor if type(name) is Struct and not name.args else (
            name if type(name) is str else None)
        agent = self.agents.get(text) if text is not None else None
        if agent is None:
            raise ctx.error(f"no agent named {term_str(name)} (agents: "
                            f"{', '.join(self.agents)})")
        return agent

    def _broadcast(self, ctx: IAContext, args: list[Any]) -> bool:
        """`.broadcast(Performative, Content)`: to every other agent."""
        perf = self._perf(ctx, args[0])
        content = value(args[1])
        for name in self.agents:
            if name != ctx.runtime.name:
                self.deliver(ctx.runtime.name, name, perf, content)
        return True

    def _all_names(self, ctx: IAContext, args: list[Any]) -> bool:
        return ctx.unify(args[0], tuple(Struct(n) for n in self.agents))


