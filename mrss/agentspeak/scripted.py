"""A host whose environment actions end when a script says so: tests and `mrss agent --stdin`.

Rules:
- every environment action is recorded (`log`, its text as `name(args)`) and numbered
  (the handle: 1, 2, ...);
- actions named in `immediate` succeed at once (default: `rcl_goal_management` and
  `give_up`, as the reasoner's host does); so do all others when `hold` is False;
- `query(Function, Args, Result)` is an open action (its Result is bound by the answer):
  answered at once from `answers` when the function is there (a value, or a callable of
  the query's arguments), else it stays open until `answer(...)` (fails at once when
  `hold` is False);
- any other action stays open until `complete`/`finish`; `cancel` (the agent dropped the
  intention) moves it from `open` to `cancelled`;
- with `virtual_time`, an agent made by `load` runs on the host's clock, which only
  `run_until` moves: straight to the next `.wait` deadline when nothing else is to be
  done (a test of the agent's retries does not wait out their pauses).
"""

from __future__ import annotations

import itertools
import time
from collections.abc import Callable, Collection, Hashable, Mapping
from pathlib import Path
from typing import Any

from mrss.agentspeak.agent import Agent
from mrss.agentspeak.literals import term as term_text
from mrss.agentspeak.terms import PList, Struct, term_str

QUERY = "query"
GOAL_MANAGEMENT = "rcl_goal_management"
GIVE_UP = "give_up"  # the reasoner's give_up(Goal, Reason, Cause): an alert, done at once


def _plain(t: Any) -> Any:
    """A query argument as a plain value (atoms as strings, lists as lists)."""
    if isinstance(t, (bool, int, float, str)):
        return t
    if isinstance(t, (tuple, list)):
        return [_plain(x) for x in t]
    if isinstance(t, PList):  # an open tail: as text, as the reasoner's host sends it
        return term_str(t)
    if isinstance(t, Struct) and not t.args and not t.annots and not t.neg:
        return t.functor
    return term_str(t)


class ScriptedHost:
    """Records the agent's actions; the test (or script) decides how each one ends."""

    open_actions = frozenset({QUERY})

    def __init__(self, *, answers: Mapping[str, Any] | None = None, hold: bool = True,
                 immediate: Collection[str] = (GOAL_MANAGEMENT, GIVE_UP),
                 on_action: Callable[[int, str], None] | None = None,
                 on_cancel: Callable[[int, str], None] | None = None,
                 virtual_time: bool = False) -> None:
        self.agent: Agent | None = None
        self.virtual_time = virtual_time
        self.now = 0.0  # the clock of a virtual-time agent (seconds)
        self.answers: dict[str, Any] = dict(answers or {})
        self.hold = hold
        self.immediate = frozenset(immediate)
        self.on_action = on_action
        self.on_cancel = on_cancel
        #: Query answers as AgentSpeak text, by function (`mrss agent --answer F=TERM`).
        self.answer_terms: dict[str, str] = {}
        self.log: list[str] = []
        self.open: dict[int, str] = {}
        self.cancelled: list[str] = []
        self.queries: dict[int, Struct] = {}  # open queries by handle
        self._ids = itertools.count(1)

    # -- building the agent ------------------------------------------------------------
    def load(self, path: str | Path, *, name: str | None = None,
             out: Callable[[str], None] | None = None) -> Agent:
        """The agent of `path` on this host, run until idle (its initial goals done)."""
        clock = (lambda: self.now) if self.virtual_time else time.monotonic
        agent = Agent.from_file(path, host=self, name=name or Path(path).stem,
                                out=out or (lambda line: None), clock=clock)
        self.agent = agent
        agent.run_until_idle()
        return agent

    # -- the Host protocol -------------------------------------------------------------
    def execute(self, action: Struct, intention_id: int) -> Hashable:
        handle = next(self._ids)
        text = term_str(Struct(action.functor, action.args))
        self.log.append(text)
        if self.on_action is not None:
            self.on_action(handle, text)
        if action.functor == QUERY and len(action.args) == 3:
            self.queries[handle] = action
            self.open[handle] = text
            function = _plain(action.args[0])
            if isinstance(function, str) and function in self.answer_terms:
                self.answer_term(handle, self.answer_terms[function])
            elif isinstance(function, str) and function in self.answers:
                self.answer(handle, self.answers[function])
            elif not self.hold:
                self.complete(handle, False, reason=f"no answer for query {function}")
        elif action.functor in self.immediate or not self.hold:
            self._agent().complete_action(handle, True)
        else:
            self.open[handle] = text
        return handle

    def cancel(self, handle: Hashable) -> None:
        number = int(str(handle))
        text = self.open.pop(number, None)
        self.queries.pop(number, None)
        if text is not None:
            self.cancelled.append(text)
            if self.on_cancel is not None:
                self.on_cancel(number, text)

    # -- what the test says ------------------------------------------------------------
    def complete(self, handle: int, ok: bool = True, *, error: str | None = None,
                 reason: str | None = None, result: str | None = None) -> None:
        """End open action `handle`: success, or failure with `error` as its cause."""
        if handle not in self.open:
            raise KeyError(f"no open action {handle}; open: {self.open}")
        self.open.pop(handle)
        self.queries.pop(handle, None)
        self._agent().complete_action(
            handle, ok, None if ok else (reason or "scripted failure"), result=result,
            error=None if ok else error)

    def finish(self, prefix: str, ok: bool = True, error: str | None = None) -> None:
        """End the one open action whose text starts with `prefix` (AssertionError unless
        exactly one does)."""
        self.complete(self.find(prefix), ok, error=error)

    def find(self, prefix: str) -> int:
        """The handle of the one open action whose text starts with `prefix`."""
        matches = [h for h, t in self.open.items() if t.startswith(prefix)]
        if len(matches) != 1:
            raise AssertionError(f"{prefix!r} among open actions {self.open}")
        return matches[0]

    def answer(self, handle: int | str, value: Any) -> None:
        """Answer an open query (by handle, or the function's name): `value` (or, if
        callable, its result for the query's arguments) binds the query's Result."""
        if isinstance(handle, str):
            handle = self.find(f"{QUERY}({handle},")
        query = self.queries.get(handle)
        if query is None:
            raise KeyError(f"no open query {handle}; open: {self.open}")
        if callable(value):
            args = _plain(query.args[1])
            value = value(*(args if isinstance(args, list) else [args]))
        self.answer_term(handle, term_text(value))

    def answer_term(self, handle: int, text: str) -> None:
        """Answer open query `handle` with a term given as AgentSpeak text."""
        query = self.queries[handle]
        result = f"{QUERY}({term_str(query.args[0])},{term_str(query.args[1])},{text})"
        self.complete(handle, True, result=result)

    def since(self, mark: int) -> list[str]:
        """The actions executed since `len(log)` was `mark`."""
        return self.log[mark:]

    # -- driving the agent -------------------------------------------------------------
    def feed(self, *percepts: str) -> None:
        """Perceive each literal (`-lit` removes it), then reason until idle."""
        agent = self._agent()
        for p in percepts:
            if p.startswith("-"):
                agent.remove_percept(p[1:])
            else:
                agent.add_percept(p.removeprefix("+"))
        agent.run_until_idle()

    def run_until(self, condition: Callable[[], bool], timeout: float = 10.0) -> None:
        """Reason (timers included: `.wait`) until `condition` holds; AssertionError after
        `timeout` seconds (of the agent's clock, with `virtual_time`)."""
        agent = self._agent()
        clock = agent.clock if self.virtual_time else time.monotonic
        deadline = clock() + timeout
        agent.run_until_idle()
        while not condition():
            if clock() >= deadline:
                raise AssertionError(f"condition did not hold within {timeout:g} s")
            due = agent.next_deadline() if self.virtual_time else None
            if due is None:
                agent.wait_for_work(0.05)
                if self.virtual_time:
                    self.now += 0.05
            elif not agent.has_work():
                self.now = max(self.now, due)  # nothing to do before it: skip to it
            agent.run_until_idle()

    def _agent(self) -> Agent:
        if self.agent is None:
            raise RuntimeError("ScriptedHost has no agent: use load() or set .agent")
        return self.agent
