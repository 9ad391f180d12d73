"""Hosts for environment actions: the protocol is `hostactions.Host`; here is the
console host used by `mrss agent`, which prints each action and succeeds at once."""

from __future__ import annotations

import itertools
import time
from collections.abc import Callable, Hashable
from typing import TYPE_CHECKING

from mrss.agentspeak.terms import Struct, term_str

if TYPE_CHECKING:
    from mrss.agentspeak.agent import Agent


class ConsoleHost:
    """Prints `action: <literal>` for each environment action and reports success."""

    def __init__(self, out: Callable[[str], None] = print) -> None:
        self.out = out
        self.agent: Agent | None = None
        self._ids = itertools.count(1)

    def execute(self, action: Struct, intention_id: int) -> Hashable:
        handle = next(self._ids)
        self.out(f"action: {term_str(action)}")
        if self.agent is not None:
            self.agent.complete_action(handle, True)
        return handle

    def cancel(self, handle: Hashable) -> None:
        self.out(f"cancel: action {handle}")


CYCLE_CHUNK = 1000  # reasoning cycles between two looks at the clock


def run_until_idle_by(agent: Agent, deadline: float | None) -> bool:
    """`agent.run_until_idle()`, but give up (False) once `time.monotonic()` passes
    `deadline`: an agent that is always busy (`+!g <- !g.`) never becomes idle."""
    while agent.run_until_idle(CYCLE_CHUNK) >= CYCLE_CHUNK:
        if deadline is not None and time.monotonic() >= deadline:
            return False
    return True


def run_standalone(agent: Agent, max_time: float | None = None) -> bool:
    """Run `agent` until it is idle (True) or `max_time` seconds pass (False), reasoning
    or sleeping on `wait_for_work` while it waits for timers or actions."""
    start = time.monotonic()
    deadline = None if max_time is None else start + max_time
    while True:
        if not run_until_idle_by(agent, deadline):
            return False
        if agent.is_idle():
            return True
        waited = time.monotonic() - start
        if max_time is not None and waited >= max_time:
            return False
        agent.wait_for_work(1.0 if max_time is None else min(1.0, max_time - waited))
