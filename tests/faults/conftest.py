"""Fixtures for fault tests: a root supervisor over real worker processes, always cleaned."""

from __future__ import annotations

from collections.abc import Callable, Iterator
from pathlib import Path
from typing import Any

import psutil
import pytest

from mrss.supervision.children import ComponentStart, ProcessSettings
from mrss.supervision.events import EventLog
from mrss.supervision.process import ProcessSupervisor
from mrss.supervision.spec import Backoff, ChildSpec, Strategy, SupervisorSpec

WORKER = "tests.projects.workers:Worker"
HEARTBEAT = 0.1
MISSES = 5
FAST_BACKOFF = Backoff(initial=0.02, cap=0.2, jitter=0.0)


def worker(cid: str, *, restart: str = "permanent", shutdown: float | str = 2.0,
           start_timeout: float = 10.0, **options: Any) -> ChildSpec[ComponentStart]:
    """A ChildSpec for tests.projects.workers:Worker with `options`."""
    return ChildSpec(cid, ComponentStart(WORKER, options, start_timeout),
                     restart=restart, shutdown=shutdown)  # type: ignore[arg-type]


class Tree:
    """A running ProcessSupervisor plus the events it published."""

    def __init__(self, sup: ProcessSupervisor, log: EventLog) -> None:
        self.sup = sup
        self.log = log

    def incarnations(self) -> dict[str, int]:
        return {c.id: c.incarnation for c in self.sup.tree().children}

    def all_running(self) -> bool:
        return all(c.state == "running" for c in self.sup.tree().children)


MakeTree = Callable[..., Tree]


def descendants() -> list[psutil.Process]:
    return [p for p in psutil.Process().children(recursive=True) if p.is_running()
            and p.status() != psutil.STATUS_ZOMBIE]


@pytest.fixture()
def make_tree(tmp_path: Path) -> Iterator[MakeTree]:
    """make_tree(*child_specs, strategy=..., intensity=..., ...) -> a started Tree."""
    before = {p.pid for p in descendants()}  # e.g. the session's MQTT broker: not ours
    trees: list[Tree] = []

    def make(*children: ChildSpec[ComponentStart], strategy: Strategy = Strategy.ONE_FOR_ONE,
             intensity: int = 3, period: float = 30.0,
             backoff: Backoff = FAST_BACKOFF,
             launcher: str = "fork", wait: bool = True, **flags: Any) -> Tree:
        log = EventLog()
        spec = SupervisorSpec(strategy=strategy, intensity=intensity, period=period,
                              backoff=backoff, **flags)
        settings = ProcessSettings(tmp_path, tmp_path, heartbeat_interval=HEARTBEAT,
                                   heartbeat_misses=MISSES, launcher=launcher)  # type: ignore[arg-type]
        sup = ProcessSupervisor("root", spec, children, settings, publish=log)
        tree = Tree(sup, log)
        trees.append(tree)
        sup.start()
        if wait:
            assert sup.wait_started(30), "children did not start"
        return tree

    try:
        yield make
    finally:
        for tree in trees:
            tree.sup.stop(timeout=30)
    left = [p for p in descendants() if p.pid not in before]
    for p in left:
        p.kill()
    assert not left, f"processes left behind: {[p.cmdline() for p in left]}"
