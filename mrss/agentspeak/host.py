"""Hosts for environment actions: the protocol lives in `runtime.Host`; here is the
console host used by `mrss agent`, which prints each action and succeeds at once."""

from __future__ import annotations

import itertools
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
