"""Jason's standard internal actions, registered in `STDLIB`."""

from __future__ import annotations

from mrss.agentspeak.registry import Registry

STDLIB = Registry()

from mrss.agentspeak.stdlib import (  # noqa: E402
    annots,
    control,
    files,
    introspect,
    lists,
    loading,
    misc,
    operator,
    plans,
    schedule,
    sets,
    strings,
    typetests,
)

__all__ = ["STDLIB", "annots", "control", "files", "introspect", "lists", "loading", "misc",
           "operator", "plans",
           "schedule", "sets", "strings", "typetests"]
