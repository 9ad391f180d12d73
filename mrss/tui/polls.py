"""How often the dashboard asks the system for what it does not push: one place for the
defaults of `mrss tui` (its options), the dashboard and `mrss bench tui`."""

from __future__ import annotations

from dataclasses import dataclass


@dataclass(frozen=True)
class Polls:
    """Seconds between the dashboard's requests (0: only on demand)."""

    mind_every: float = 1.0  # a mind snapshot of the reasoner (0: only on m)
    tree_every: float = 2.0  # the root's supervision tree (0: only on F5)
    world_every: float = 2.0  # the world model's objects, for the map (0: on connecting, F5)
    stale_after: float = 5.0  # nothing heard for this long: the header turns red


DEFAULT_POLLS = Polls()
