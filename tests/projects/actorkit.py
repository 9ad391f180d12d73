"""Small supervised actors for the actor supervision and fault tests.

State that must survive a restart lives in a `Store` outside the actor; the start hook
(`setup`) rebuilds the actor's state from it, as a real robot actor reloads its journal.
"""

from __future__ import annotations

import threading
from dataclasses import dataclass, field
from typing import Any

import pykka

from mrss.supervision.actors import ActorContext, ActorSupervisor, SupervisedActor
from mrss.supervision.spec import SupervisorSpec


@dataclass
class Store:
    """What outlives an incarnation: committed values, and a trace of lifecycle calls."""

    committed: dict[str, int] = field(default_factory=dict)
    trace: list[str] = field(default_factory=list)
    lock: threading.Lock = field(default_factory=threading.Lock)
    fail_setup: set[str] = field(default_factory=set)

    def note(self, entry: str) -> None:
        with self.lock:
            self.trace.append(entry)


class Counter(SupervisedActor):
    """Counts; `commit` saves the count to the store, `setup` reloads it."""

    caller_errors = (KeyError,)

    def __init__(self, ctx: ActorContext, store: Store) -> None:
        super().__init__(ctx)
        self.store = store
        self.count = -1

    def setup(self) -> None:
        if self.ctx.child in self.store.fail_setup:
            raise RuntimeError(f"{self.ctx.child} cannot start")
        self.count = self.store.committed.get(self.ctx.child, 0)
        self.store.note(f"setup {self.ctx.child} {self.ctx.incarnation}")

    def teardown(self) -> None:
        self.store.note(f"teardown {self.ctx.child} {self.ctx.incarnation}")

    def add(self, n: int) -> int:
        self.count += n
        return self.count

    def commit(self) -> None:
        self.store.committed[self.ctx.child] = self.count

    def get(self) -> tuple[int, int]:
        """(count, incarnation)."""
        return self.count, self.ctx.incarnation

    def lookup(self, key: str) -> int:
        """Raises KeyError, which is a caller error: the actor survives it."""
        return self.store.committed[key]

    def divide(self, n: int) -> float:
        return self.count / n

    def lose_link(self, reason: str) -> None:
        self.link_down(reason)

    def finish(self) -> None:
        self.stop()


def counter(store: Store) -> Any:
    """A factory for Counter children sharing `store`."""
    return lambda ctx: Counter.start(ctx, store)


def nested(spec: SupervisorSpec, children: list[Any]) -> Any:
    """A factory for a nested ActorSupervisor child."""
    return lambda ctx: ActorSupervisor.start(spec, children, ctx=ctx)


def stop_every_actor(timeout: float = 30.0) -> None:
    """End a test's actors from the top: its supervisors first, oldest (the root) first,
    each stopping its own children, then whatever is left. `ActorRegistry.stop_all`
    alone stops the newest first, children before their supervisor, and a supervisor
    still running restarts a child it sees go: that child outlived the test and logged
    its start into a closed stream. None may be left afterwards."""
    for ref in pykka.ActorRegistry.get_by_class(ActorSupervisor):
        ref.stop(block=True, timeout=timeout)
    pykka.ActorRegistry.stop_all(block=True, timeout=timeout)
    left = pykka.ActorRegistry.get_all()
    assert not left, f"actors left running after the test: {left}"
