"""Jason's standard internal actions, registered in `STDLIB`."""

from __future__ import annotations

from mrss.agentspeak.registry import Registry

STDLIB = Registry()

from mrss.agentspeak.stdlib import control, lists, misc, plans, typetests  # noqa: E402

__all__ = ["STDLIB", "control", "lists", "misc", "plans", "typetests"]
