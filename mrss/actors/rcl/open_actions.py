"""The RCL's open actions: where each one runs, for which goal and requester, and the
state last published for it.

One object, shared by the core and its collaborators (requesters, availability,
observers), with one re-entrant lock. The lock is held from an action's journal commit
to its publication (`RclCore._emit`), so whoever reads the open actions under it sees
what was published, never half a transition; progress and snapshots take it too.
"""

from __future__ import annotations

import threading
from collections.abc import Callable
from typing import NamedTuple, Protocol

from mrss.actors.rcl import lifecycle as lc
from mrss.actors.rcl.action import Action
from mrss.actors.rcl.journal import Requester
from mrss.messages import ActionState


class Entry(NamedTuple):
    """An open action as the core routes it."""

    robot: str
    goal: str
    state: ActionState
    requester: Requester


class OpenActions:
    """uuid -> Entry of every non-terminal action, under one re-entrant lock."""

    def __init__(self) -> None:
        self.lock = threading.RLock()
        self._entries: dict[str, Entry] = {}

    def get(self, uuid: str) -> Entry | None:
        with self.lock:
            return self._entries.get(uuid)

    def __contains__(self, uuid: str) -> bool:
        with self.lock:
            return uuid in self._entries

    def put(self, action: Action, requester: Requester) -> None:
        with self.lock:
            self._entries[action.uuid] = Entry(action.robot, action.goal, action.state,
                                               requester)

    def replace(self, uuid: str, requester: Requester) -> None:
        """The action has a new requester (an adoption)."""
        with self.lock:
            known = self._entries.get(uuid)
            if known is not None:
                self._entries[uuid] = known._replace(requester=requester)

    def drop(self, uuid: str) -> None:
        with self.lock:
            self._entries.pop(uuid, None)

    def matching(self, keep: Callable[[str, Entry], bool]) -> dict[str, Entry]:
        """The open actions `keep(uuid, entry)` selects, as one consistent view."""
        with self.lock:
            return {u: e for u, e in self._entries.items() if keep(u, e)}

    def of_robot(self, robot: str) -> list[str]:
        """The uuids of `robot`'s open actions, oldest first."""
        return list(self.matching(lambda _u, e: e.robot == robot))

    def states(self) -> dict[str, ActionState]:
        with self.lock:
            return {u: e.state for u, e in self._entries.items()}


class Routes(Protocol):
    """What the core does for its collaborators: reach a robot actor, end an action no
    actor runs, publish an action's status (journaled already)."""

    def tell(self, robot: str, message: object) -> None: ...

    def control_one(self, uuid: str, event: lc.Suspend | lc.Resume | lc.End) -> None: ...

    def end_unrouted(self, action: Action, end: lc.End) -> None: ...

    def publish_status(self, action: Action, repeat: bool = False) -> None: ...
