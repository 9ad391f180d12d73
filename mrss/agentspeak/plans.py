"""Compiled plans and the plan library, indexed by trigger operator and predicate."""

from __future__ import annotations

from typing import TYPE_CHECKING, Any

from mrss.agentspeak.closures import tester
from mrss.agentspeak.selection import Selector, selector
from mrss.agentspeak.terms import GOAL_STATE, OP_TEXT, Slot, Struct, Term, term_str

if TYPE_CHECKING:
    from mrss.agentspeak.formulas import Query

SELF = Struct("self")
PlanKey = tuple[int, str, int, bool]


class Plan:
    """A plan ready to run: trigger template, compiled context and body code."""

    __slots__ = ("label", "op", "trigger", "context", "code", "nslots", "atomic", "line",
                 "file", "index", "annots", "varnames", "arg_slots", "test", "pad", "const_args",
                 "src", "plabel", "sources")

    def __init__(self, label: Struct | None, op: int, trigger: Struct, context: Query | None,
                 code: list[Any], nslots: int, line: int, file: str,
                 annots: tuple[Term, ...] = (), varnames: list[str] | None = None) -> None:
        self.label = label
        self.src: Any = None  # the PlanSrc, for plan terms (`.relevant_plans`)
        # the label in the library (`p__N` when the source gives none) and its sources
        self.plabel: Struct | None = None
        self.sources: list[Term] = []
        self.varnames = varnames or []
        self.op = op
        self.trigger = trigger
        self.context = context
        # the context as one Python function when it is simple enough (see `closures`)
        self.test = tester(context)
        self.code = code
        self.nslots = nslots
        self.annots = annots
        self.atomic = any(type(a) is Struct and a.functor == "atomic" for a in annots)
        self.line = line
        self.file = file
        self.index = 0
        # a trigger whose arguments are distinct variables, without annotations, matches
        # any event of its predicate: binding is a plain copy into the frame
        self.arg_slots: tuple[int, ...] | None = None
        if not trigger.annots and all(type(a) is Slot for a in trigger.args):
            idx = tuple(a.index for a in trigger.args if type(a) is Slot)
            if len(set(idx)) == len(idx):
                self.arg_slots = idx
        # ... and when they are slots 0, 1, ..., the frame is the event's arguments padded
        self.pad: tuple[None, ...] | None = None
        if self.arg_slots is not None and self.arg_slots == tuple(range(len(trigger.args))):
            self.pad = (None,) * (nslots - len(trigger.args))
        # a trigger whose arguments are numbers and strings, without annotations: a ground
        # event matches it when the arguments are equal (what unification would decide)
        self.const_args: tuple[Term, ...] | None = None
        if not trigger.annots and all(type(a) in (int, float, str) for a in trigger.args):
            self.const_args = trigger.args

    @property
    def key(self) -> PlanKey:
        t = self.trigger
        return (self.op, t.functor, len(t.args), t.neg)

    def trigger_text(self) -> str:
        return OP_TEXT[self.op] + term_str(self.trigger)

    def name(self) -> str:
        """The label if any, else `file:line`."""
        if self.label is not None:
            return term_str(self.label)
        return f"{self.file}:{self.line}"


class PlanLibrary:
    """All plans in source order, indexed by (operator, functor, arity, negation)."""

    def __init__(self) -> None:
        self.plans: list[Plan] = []
        self.index: dict[PlanKey, list[Plan]] = {}
        # per key, its plans' selection compiled (`selection`); built on first use,
        # forgotten whenever a plan is added or removed
        self.selectors: dict[PlanKey, Selector | None] = {}
        self.labels: dict[str, Plan] = {}  # by the label's functor, as in Jason
        self._auto = 0
        self.meta = 0  # how many plans handle goal-state meta-events (`^!g`)
        # changes whenever a plan is added or removed: what a formula's `OwnEvent` keeps
        # of this library (its key's selection) holds while the version is the same
        self.version = 0

    def _label(self, plan: Plan, source: Term) -> None:
        if plan.label is not None:
            plan.plabel = Struct(plan.label.functor, plan.label.args)
        else:  # Jason 3.1 automatic labels (PlanLibrary.getUniqueLabel): p__1, p__2, ...
            while True:
                self._auto += 1
                name = f"p__{self._auto}"
                if name not in self.labels:
                    break
            plan.plabel = Struct(name)
        plan.sources = [source]
        self.labels.setdefault(plan.plabel.functor, plan)

    def add(self, plan: Plan, begin: bool = False, source: Term = SELF) -> None:
        """Add `plan` after all others (or, with `begin`, before all others)."""
        self._label(plan, source)
        self.selectors.clear()
        self.version += 1
        if plan.op == GOAL_STATE:
            self.meta += 1
        if begin:
            self.plans.insert(0, plan)  # new lists: an event may be iterating the old
            self.index[plan.key] = [plan] + self.index.get(plan.key, [])
            for i, p in enumerate(self.plans):
                p.index = i
            return
        plan.index = len(self.plans)
        self.plans.append(plan)
        self.index.setdefault(plan.key, []).append(plan)

    def remove(self, plan: Plan) -> None:
        if plan.plabel is not None and self.labels.get(plan.plabel.functor) is plan:
            del self.labels[plan.plabel.functor]
        self.plans.remove(plan)
        self.selectors.clear()
        self.version += 1
        if plan.op == GOAL_STATE:
            self.meta -= 1
        same = [p for p in self.index[plan.key] if p is not plan]
        if same:
            self.index[plan.key] = same
        else:
            del self.index[plan.key]
        for i, p in enumerate(self.plans):
            p.index = i

    def labelled(self, label: Struct) -> Plan | None:
        """The plan whose label has the functor of `label` (as in Jason)."""
        return self.labels.get(label.functor)

    def selector(self, key: PlanKey) -> Selector | None:
        """The compiled selection among the plans of `key`; None when it has none."""
        plans = self.index.get(key)
        sel = self.selectors[key] = selector(plans, key[2]) if plans else None
        return sel

    def relevant(self, op: int, lit: Struct) -> list[Plan] | None:
        return self.index.get((op, lit.functor, len(lit.args), lit.neg))

    def has(self, op: int, key: tuple[str, int, bool]) -> bool:
        return (op, key[0], key[1], key[2]) in self.index
