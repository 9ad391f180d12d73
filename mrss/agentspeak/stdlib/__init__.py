"""Jason's standard internal actions, registered in `STDLIB`."""

from __future__ import annotations

from mrss.agentspeak.registry import Registry

STDLIB = Registry()

from mrss.agentspeak.stdlib import (  # noqa: E402
    control,
    introspect,
    lists,
    misc,
    plans,
    schedule,
    typetests,
)

__all__ = ["STDLIB", "control", "introspect", "lists", "misc", "plans", "schedule",
           "typetests"]
