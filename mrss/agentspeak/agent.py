"""`Agent`: one AgentSpeak agent -- load a program, feed percepts, run reasoning cycles.

Threading: `step`, `run_until_idle`, `snapshot` and the other reasoning calls belong to
one thread (the reasoner's loop). `add_percept`, `remove_percept`, `post_goal` and
`complete_action` may be called from any thread: they queue work under a lock and wake
`wait_for_work`, and the next cycle applies it.
"""

from __future__ import annotations

import sys
import threading
import time
from collections import deque
from collections.abc import Callable, Hashable, Iterable
from pathlib import Path
from typing import Any

from mrss.agentspeak.compile import compile_program
from mrss.agentspeak.depth import ensure_recursion_limit
from mrss.agentspeak.errors import AslRuntimeError, AslSyntaxError, SyntaxProblem
from mrss.agentspeak.hostactions import Host
from mrss.agentspeak.intentions import RUNNABLE
from mrss.agentspeak.parser import parse_literal, parse_program
from mrss.agentspeak.registry import Registry
from mrss.agentspeak.runtime import Runtime
from mrss.agentspeak.snapshot import take_snapshot
from mrss.agentspeak.termorder import add_annot
from mrss.agentspeak.terms import (
    ADD_BEL,
    DEL_BEL,
    SOURCE_PERCEPT,
    Struct,
)
from mrss.textfile import NotUtf8Error, read_text


def _print_line(text: str) -> None:
    sys.stdout.write(text + "\n")
    sys.stdout.flush()


def default_registry() -> Registry:
    """The registry with Jason's standard internal actions."""
    from mrss.agentspeak.stdlib import STDLIB

    return STDLIB


class Agent(Runtime):
    """A Jason-compatible AgentSpeak agent.

    `source` is the program text (`file` names it in messages), or pass `file` alone to
    read it. `host` receives environment actions. `beliefs` are extra initial beliefs
    (like Jason's `.mas2j` `beliefs=`), `actions` a registry with project internal
    actions (see `Registry.child`), `clock` a monotonic clock in seconds (for `.wait`),
    `out` receives each `.print` line.
    """

    def __init__(self, source: str | None = None, *, file: str | Path | None = None,
                 host: Host | None = None, name: str = "agent",
                 beliefs: Iterable[str | Struct] = (), actions: Registry | None = None,
                 clock: Callable[[], float] = time.monotonic,
                 out: Callable[[str], None] | None = None) -> None:
        super().__init__(name, host, actions or default_registry(), clock, out or _print_line)
        ensure_recursion_limit()  # deep terms and rule recursion (see `depth`)
        if source is None:
            if file is None:
                raise ValueError("Agent needs a source text or a file")
            source = read_program(Path(file))
        self.file = str(file) if file is not None else "<string>"
        problems: list[SyntaxProblem] = []
        program = parse_program(source, self.file, collect=problems)
        compiled = compile_program(program, self.registry, source, problems)
        compiled.functions.rt = self
        initial = self._add_initial(compiled.clauses)
        bad: list[SyntaxProblem] = []
        for number, extra in enumerate(beliefs, start=1):
            from mrss.agentspeak.compile import with_self_source

            try:
                belief = with_self_source(parse_literal(extra))
            except (AslSyntaxError, AslRuntimeError) as exc:  # e.g. b(X+1): X is unbound
                reason = exc.problems[0].message if isinstance(exc, AslSyntaxError) else exc
                bad.append(SyntaxProblem("beliefs", number, 1,
                                         f"initial belief {str(extra)!r}: {reason}", str(extra)))
                continue
            self.bb.add(belief, front=False)
        if bad:
            raise AslSyntaxError(bad)
        for plan in compiled.plans:
            self.plans.add(plan)
        for lit in initial:
            self.belief_changed(ADD_BEL, lit, None)
        for goal in compiled.goals:
            self.post_goal(goal, None)
        self._cond = threading.Condition()
        self._inbox: deque[tuple[str, Any, Any, Any]] = deque()
        self._woken = False
        # told of each input, in a society (`rounds.Rounds.mark` of this agent)
        self._mark: Callable[[], None] | None = None

    def _add_initial(self, clauses: list[Struct | Any]) -> list[Struct]:
        """Add the program's facts and rules as Jason's `Agent.addInitialBelsInBB` does:
        from the last to the first, each put before the others, so a fact written twice
        takes the place of its last copy; returns the facts that were new (or brought
        new annotations), in that order: each gets its `+b` event, as in Jason."""
        last: dict[tuple[Any, ...], int] = {}
        for i, c in enumerate(clauses):
            if type(c) is Struct:
                last[(c.functor, c.neg, c.args)] = i
        new: list[Struct] = []
        seen: dict[tuple[Any, ...], set[Any]] = {}
        for c in reversed(clauses):
            if type(c) is Struct:
                annots = seen.setdefault((c.functor, c.neg, c.args), set())
                if not annots or not annots.issuperset(c.annots):
                    new.append(c)
                annots.update(c.annots)
        later: list[Struct] = []
        for i, c in enumerate(clauses):  # in the order they end up in
            if type(c) is Struct:
                if last[(c.functor, c.neg, c.args)] == i:
                    self.bb.add(c, front=False)
                else:
                    later.append(c)
            else:
                h = c.head  # type: ignore[union-attr]
                self.bb.add_rule((h.functor, len(h.args), h.neg), c)  # type: ignore[arg-type]
        for c in later:  # an earlier copy adds its annotations only
            self.bb.add(c, front=False)
        return new

    @property
    def society(self) -> Any:
        """The `society.Society` this agent talks in, if any (kept in `extras`)."""
        return self.extras.society

    @society.setter
    def society(self, society: Any) -> None:
        self.extras.society = society

    @classmethod
    def from_file(cls, path: str | Path, **kwargs: Any) -> Agent:
        return cls(file=path, **kwargs)

    # ------------------------------------------------------------------ thread-safe input
    def _put(self, item: tuple[str, Any, Any, Any]) -> None:
        with self._cond:
            self._inbox.append(item)
            if self._mark is not None:
                self._mark()
            self._cond.notify_all()

    def wake(self) -> None:
        """Make a `wait_for_work` in the loop thread (the agent's, or its society's)
        return now (e.g. to stop)."""
        with self._cond:
            self._woken = True
            if self.society is not None:
                self.society.woken = True
            self._cond.notify_all()

    def add_percept(self, literal: str | Struct) -> None:
        """Perceive `literal` (text or Struct): a belief `[source(percept)]` and its event."""
        self._put(("+", parse_literal(literal), None, None))

    def remove_percept(self, literal: str | Struct) -> None:
        """Stop perceiving `literal`: its `source(percept)` goes, posting `-literal`."""
        self._put(("-", parse_literal(literal), None, None))

    def add_goal(self, literal: str | Struct) -> None:
        """An external achievement goal `+!literal` (starts a new intention)."""
        self._put(("!", parse_literal(literal), None, None))

    def complete_action(self, handle: Hashable, success: bool, reason: str | None = None,
                        result: str | Struct | None = None, error: str | None = None) -> None:
        """The host reports the outcome of the action it returned `handle` for. For an
        action the host lists in `open_actions`, `result` is unified with the action
        literal (a mismatch fails the action). A failure posts `-!g[error(E)]` with `error`
        as E (an atom naming the cause, as Jason's failure reason), else `action_failed`."""
        res = parse_literal(result) if isinstance(result, str) else result
        self._put(("done", handle, success, (reason, res, error)))

    # ------------------------------------------------------------------ the cycle
    def _drain(self) -> None:
        with self._cond:
            items = list(self._inbox)
            self._inbox.clear()
        for kind, a, b, c in items:
            if kind == "done":
                self.completed.append((a, b, c[0], c[1], c[2]))
            elif kind == "+":
                lit = a if SOURCE_PERCEPT in a.annots else \
                    Struct(a.functor, a.args, add_annot(a.annots, SOURCE_PERCEPT), a.neg)
                if self.bb.add(lit, front=True):
                    self.belief_changed(ADD_BEL, lit, None)
            elif kind == "-":
                lit = Struct(a.functor, a.args, (SOURCE_PERCEPT,), a.neg)
                if self.bb.remove(lit):
                    self.belief_changed(DEL_BEL, lit, None)
            elif kind == "!":
                self.post_goal(a, None)
            elif kind == "msg":  # from another agent of the society: (sender, perf, content)
                from mrss.agentspeak.society import receive
                receive(self, a, b, c)

    def step(self) -> bool:
        """One reasoning cycle (sense, deliberate, act); False if there was nothing to do."""
        self.cycle += 1
        busy = False
        if self._inbox:
            self._drain()
            busy = True
        if self.timers and self.timers[0][0] <= self.clock():
            busy = self.expire_timers(self.clock()) or busy
        # deliberate: one event (while an [atomic] intention runs, only its own events)
        if self.atomic_events:
            self.handle_event(self.atomic_events.popleft())
            busy = True
        elif self.events and self.atomic is None:
            self.handle_event(self.events.popleft())
            busy = True
        # act: one finished action, then one step of one intention
        if self.completed:
            self.process_completion(*self.completed.popleft())
            busy = True
        atomic = self.atomic
        if atomic is not None:
            if atomic.state is RUNNABLE and not atomic.suspended and not atomic.dropped:
                self.run_step(atomic)
                busy = True
            return busy
        runq = self.runq
        while runq:
            it = runq.popleft()
            it.in_queue = False
            if it.state is RUNNABLE and not it.dropped and not it.suspended:
                self.run_step(it)
                return True
        return busy

    def run_until_idle(self, max_cycles: int | None = None) -> int:
        """Run cycles until nothing is left to do now (parked intentions may remain);
        returns the number of busy cycles."""
        n = 0
        limit = -1 if max_cycles is None else max(max_cycles, 1)
        step = self.step
        run_step = self.run_step
        # the cycle's queues, never replaced: read here without an attribute lookup
        runq, events, atomic_events = self.runq, self.events, self.atomic_events
        completed, inbox, timers = self.completed, self._inbox, self.timers
        while n != limit:
            # The lone intention's lane: one runnable intention and nothing else for a
            # cycle to do (no input, event, finished action, timer or [atomic] one):
            # `step` would only take it from the queue and run one formula of it.
            if (len(runq) == 1 and not events and not inbox and not completed
                    and not atomic_events and not timers and self.atomic is None):
                it = runq[0]
                if it.state is RUNNABLE and not it.dropped and not it.suspended:
                    runq.popleft()
                    it.in_queue = False
                    self.cycle += 1
                    run_step(it)
                    n += 1
                    continue
            if not step():
                break
            n += 1
        return n

    def has_work(self) -> bool:
        """Whether a cycle now would do something."""
        if self._inbox or self.events or self.atomic_events or self.completed:
            return True
        if any(it.state is RUNNABLE and not it.dropped and not it.suspended for it in self.runq):
            return True
        deadline = self.next_deadline()
        return deadline is not None and deadline <= self.clock()

    def wait_for_work(self, timeout: float | None = None) -> bool:
        """Block until there is work (new input, or a `.wait` deadline reached) or
        `timeout` real seconds pass; True if there is work."""
        end = None if timeout is None else time.monotonic() + timeout
        with self._cond:
            while not self.has_work():
                if self._woken:
                    self._woken = False
                    return False
                remaining = None if end is None else end - time.monotonic()
                deadline = self.next_deadline()
                if deadline is not None:
                    until_deadline = max(deadline - self.clock(), 0.0)
                    remaining = until_deadline if remaining is None else min(remaining,
                                                                             until_deadline)
                if remaining is not None and remaining <= 0:
                    return self.has_work()
                self._cond.wait(remaining)
            return True

    def is_idle(self) -> bool:
        """Nothing to do now and nothing that will make work by itself: no environment
        action in progress and no `.wait` deadline. (Intentions waiting for an event
        or a condition only wake on new input, so they do not count.)"""
        return not self.has_work() and not self.pending_actions and self.next_deadline() is None

    # ------------------------------------------------------------------ inspection
    def snapshot(self, action_id: Callable[[Hashable], Hashable] | None = None
                 ) -> dict[str, Any]:
        """Beliefs, intentions (with stacks) and pending events as plain JSON-able data;
        `action_id` maps an action handle to the id shown (the host's, by default the
        handle itself)."""
        return take_snapshot(self, action_id or (lambda handle: handle))

    def beliefs(self) -> list[str]:
        return self.bb.texts()

    def believes(self, literal: str | Struct) -> bool:
        """Whether some belief matches `literal` (a query, as in a plan context)."""
        from mrss.agentspeak.formulas import LiteralQuery

        lit = parse_literal(literal)
        for _ in LiteralQuery(lit).solve(self, []):
            self.trail.clear()
            return True
        return False


def read_program(path: Path) -> str:
    """A program file's text (OSError if unreadable; AslSyntaxError if not UTF-8)."""
    try:
        return read_text(path)
    except NotUtf8Error as exc:
        raise AslSyntaxError([SyntaxProblem(exc.file, exc.line, exc.col, exc.reason,
                                            exc.source_line)]
                             ) from None
