"""Adoption: which of a dead incarnation's actions a new reasoner incarnation takes over,
read from the RCL's inventory (DESIGN.md, "Mission state survives what process state need
not": open actions of a dead reasoner are adopted, not cancelled and redone)."""

from __future__ import annotations

from typing import Any

from mrss.messages import ActionState


def adoptable(items: list[dict[str, Any]]) -> dict[str, list[str]]:
    """What a new incarnation may adopt, by literal, from the RCL's inventory (oldest
    first): the actions still open; for a literal with none open, the last one that
    ended (its outcome may never have reached the dead incarnation). An older try that
    ended before a newer one of the same literal was requested was seen to end (the
    predecessor tried again): adopting it would fail the re-derived intention at once
    and use up one of its retries while the newer try runs on as an orphan."""
    open_: dict[str, list[str]] = {}
    ended: dict[str, str] = {}
    for item in items:
        literal, uuid, state = item.get("literal"), item.get("uuid"), item.get("state")
        if not (isinstance(literal, str) and isinstance(uuid, str) and literal):
            continue
        try:
            terminal = ActionState(str(state)).terminal
        except ValueError:
            terminal = False  # unknown: as good as open
        if terminal:
            ended[literal] = uuid
        else:
            open_.setdefault(literal, []).append(uuid)
    return {literal: open_.get(literal) or [ended[literal]]
            for literal in {**ended, **open_}}

