"""What a project's test procedures import: the agent on a scripted host, the real system.

- `ScriptedHost` (rules in mrss.agentspeak.scripted): the agent alone, on the real
  interpreter; every environment action is recorded and stays open until the test ends
  it; `query(F, Args, R)` is answered from `answers` or by `answer(...)`:

      host = ScriptedHost(answers={"area_polygon": [[-35.36, 149.16], ...]})
      agent = host.load(PROJECT / "agent.asl")
      host.feed("area_goal_received(a1, 2)")
      assert list(host.open.values()) == ["cover(uav1,a1)"]
      host.finish("cover(uav1,a1)")                 # or ok=False, error="link_down"

- `RunningProject` (mrss.procedures): `mrss supervise` as its own process, watched
  from outside (bus, world model, broker); docs/projects.md, "RunningProject".
- `memory_world(objects)`: an embedded world model in this process (in-memory SQLite,
  the same spatial predicates as the running one), seeded with `objects`, as a data
  layer's `self.world` sees it: for unit tests of functions over the world model.
- `wait_until(condition, timeout)`: poll a condition instead of sleeping.
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import Any

from mrss.actors.worldmodel.local import LocalWorldModel
from mrss.actors.worldmodel.model import WorldModel
from mrss.actors.worldmodel.sqlite import SqliteWorldStore
from mrss.agentspeak.agent import Agent
from mrss.agentspeak.scripted import ScriptedHost
from mrss.procedures import RunningProject
from mrss.testing import WaitTimeout, free_port, free_udp_port, wait_until

__all__ = ["Agent", "LocalWorldModel", "RunningProject", "ScriptedHost", "WaitTimeout",
           "free_port", "free_udp_port", "memory_world", "wait_until"]


def memory_world(objects: Sequence[dict[str, Any]] = ()) -> LocalWorldModel:
    """An in-memory world model seeded with `objects` (a seed file's entries)."""
    world = WorldModel(SqliteWorldStore(":memory:"))
    world.seed(list(objects), source="memory_world")
    return LocalWorldModel(world)
