"""Rules of the world model: project code that reacts to inserts and updates with percepts.

A rule sees each `Change` (after it is stored) and the store, and returns literal strings
to publish as percepts. Write one with the decorator, or use a built-in:

    @rule(kind="hotspot", ops=("insert",))
    def big_fire(change, world):
        if change.obj.attributes.get("intensity", 0) > 5:
            yield literal("big_fire", symbol(change.obj.id))

    NoObjectWithin("hotspot", "water_source", radius_m=500, functor="hotspot_detected")

A project lists its rules in `projects/<name>/worldmodel.py` as `def rules(options) ->
list[Rule]`. A rule that raises is logged and counted; the others still run.
"""

from __future__ import annotations

import logging
from collections.abc import Callable, Iterable, Sequence
from dataclasses import dataclass, field
from typing import Protocol

from mrss.actors.worldmodel.store import Change, ChangeOp, WorldStore
from mrss.agentspeak.literals import check_literal, literal, symbol

log = logging.getLogger("mrss.worldmodel.rules")


class Rule(Protocol):
    """Something that turns a stored change into zero or more percept literals."""

    @property
    def name(self) -> str:
        """Shown in logs when the rule fails."""
        ...

    def fire(self, change: Change, world: WorldStore) -> Iterable[str]:
        """Literals to publish for this change."""
        ...


RuleBody = Callable[[Change, WorldStore], Iterable[str]]


@dataclass(frozen=True)
class FunctionRule:
    """A rule from a function, filtered by object kind and change operation."""

    name: str
    body: RuleBody
    kind: str | None = None
    ops: tuple[ChangeOp, ...] = ("insert", "update")

    def fire(self, change: Change, world: WorldStore) -> Iterable[str]:
        if change.op not in self.ops or (self.kind and change.obj.kind != self.kind):
            return ()
        return self.body(change, world)


def rule(kind: str | None = None, ops: Sequence[ChangeOp] = ("insert", "update"),
         name: str | None = None) -> Callable[[RuleBody], FunctionRule]:
    """Decorator making a rule of a function `(change, world) -> literals`."""
    def wrap(body: RuleBody) -> FunctionRule:
        return FunctionRule(name or body.__name__, body, kind, tuple(ops))
    return wrap


@dataclass(frozen=True)
class NoObjectWithin:
    """A new object of `kind` with no `other` object within `radius_m` metres.

    Emits `functor(Id, Lat, Lon)`, e.g. a hotspot with no water source in reach:
    `hotspot_detected(h1, 43.6, 1.44)`. Objects without a position are ignored.
    """

    kind: str
    other: str
    radius_m: float
    functor: str
    ops: tuple[ChangeOp, ...] = ("insert",)
    name: str = field(default="")

    def __post_init__(self) -> None:
        if not self.name:
            object.__setattr__(self, "name", f"no_{self.other}_within_{self.radius_m:g}m")
        if self.radius_m < 0:
            raise ValueError("radius_m must not be negative")

    def fire(self, change: Change, world: WorldStore) -> Iterable[str]:
        obj = change.obj
        if change.op not in self.ops or obj.kind != self.kind or obj.position is None:
            return []
        if world.near(obj.position, self.radius_m, kind=self.other):
            return []
        return [literal(self.functor, symbol(obj.id), obj.position.lat, obj.position.lon)]


class RuleEngine:
    """The registered rules, applied in registration order to every change."""

    def __init__(self, rules: Iterable[Rule] = ()) -> None:
        self.rules: list[Rule] = list(rules)
        self.errors = 0
        self.fired = 0

    def register(self, new_rule: Rule) -> None:
        """Add a rule."""
        self.rules.append(new_rule)

    def apply(self, change: Change, world: WorldStore) -> list[str]:
        """The literals every rule emits for `change`; a failing rule is logged and skipped."""
        if change.op == "unchanged":
            return []
        out: list[str] = []
        for each in self.rules:
            try:
                emitted = [check_literal(text) for text in each.fire(change, world)]
            except Exception:
                self.errors += 1
                log.exception("world model rule %r failed on %s %r", getattr(each, "name", each),
                              change.op, change.obj.id)
                continue
            self.fired += len(emitted)
            out.extend(emitted)
        return out
