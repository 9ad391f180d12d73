"""Which agents of a society a round of reasoning cycles steps: only those that may
have work, in the order the agents were given, so a round costs what its busy agents
do and not the number of agents.

The rounds are those of deterministic round-robin (one cycle of each agent, in
order, then again), with the idle agents left out: an agent stepped without work
does nothing, so skipping it changes nothing. An agent is *ready* from the moment it
may have work until a step of it finds none: when it joins (its initial goals),
when input is put in its inbox (a message, a percept, a finished action: any thread,
under the society's lock, `mark`), and while its steps are busy. An agent found idle
with a `.wait`/`.at` timer is kept in a heap by deadline and made ready when the
deadline passes. A message from the agent being stepped to one later in the order is
handled in the same round, as when every agent was stepped (the current round is a
heap of agent positions); input from another thread waits for the next round. The
loop's thread takes the lock once a round, not once a step.
"""

from __future__ import annotations

import functools
import heapq
import threading
from typing import TYPE_CHECKING

if TYPE_CHECKING:
    from mrss.agentspeak.agent import Agent


class Rounds:
    """The ready agents of one society and their rounds. `cond` is the society's lock:
    input from any thread takes it to mark its agent; the thread running the rounds
    (the loop) takes it once a round, and owns the round's heap and the timers."""

    def __init__(self, cond: threading.Condition) -> None:
        self._cond = cond
        self.agents: list[Agent] = []
        self._ready: set[int] = set()  # positions for the next round (under the lock)
        self._current: list[int] = []  # the round being run: a heap of positions
        self._queued: set[int] = set()  # what is in _current
        self._pos = -1  # the position being stepped (-1: between rounds)
        self._owner = 0  # the thread running the round
        self._timers: list[tuple[float, int]] = []  # (deadline, position) of idle agents

    def add(self, agent: Agent) -> None:
        """A new agent, ready (its initial goals and beliefs are work); its input marks
        it (`mark`)."""
        with self._cond:
            slot = len(self.agents)
            self.agents.append(agent)
            self._ready.add(slot)
            agent._mark = functools.partial(self.mark, slot)

    def mark(self, slot: int) -> None:
        """The agent at `slot` may have work (the caller holds the lock). Sent by an
        agent of the round to one later in the order: this round, as if every agent
        were stepped; from another thread (a percept, an action's outcome): the next."""
        if slot > self._pos >= 0 and threading.get_ident() == self._owner:
            if slot not in self._queued:
                self._queued.add(slot)
                heapq.heappush(self._current, slot)
        else:
            self._ready.add(slot)

    def has_work(self) -> bool:
        """Whether some agent is ready or has a deadline that passed (under the lock,
        in the loop's thread)."""
        if self._ready:
            return True
        timers = self._timers
        return bool(timers) and timers[0][0] <= self.agents[timers[0][1]].clock()

    def next_deadline(self) -> float | None:
        """The earliest deadline of an idle agent's timer (on the agents' clock)."""
        return self._timers[0][0] if self._timers else None

    def round(self) -> bool:
        """One cycle of each ready agent, in order; True if one was busy."""
        agents = self.agents
        timers = self._timers
        with self._cond:
            while timers and timers[0][0] <= agents[timers[0][1]].clock():
                self._ready.add(heapq.heappop(timers)[1])
            if not self._ready:
                return False
            current = self._current = sorted(self._ready)  # a sorted list is a heap
            queued = self._queued = set(current)
            self._ready = set()
            self._owner = threading.get_ident()
        busy = False
        again: list[int] = []
        pop = heapq.heappop
        try:
            while current:
                slot = pop(current)
                queued.discard(slot)
                self._pos = slot
                agent = agents[slot]
                if agent.step():
                    busy = True
                    again.append(slot)
                elif agent.timers:
                    deadline = agent.next_deadline()
                    if deadline is not None:
                        heapq.heappush(timers, (deadline, slot))
        finally:
            with self._cond:
                self._pos = -1
                self._ready.update(again)
                self._ready.update(current)  # left by an exception
                self._current = []
                self._queued = set()
        return busy

    def idle(self) -> bool:
        """Nothing to do now nor later by itself (no action in progress, no timer): a
        look at every agent, taken only when a round found none busy."""
        return not self._ready and all(a.is_idle() for a in self.agents)
