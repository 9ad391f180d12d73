"""The belief base: beliefs and rules indexed by predicate indicator, in Jason's order.

Per functor/arity/negation, beliefs live in two insertion-ordered dicts keyed by their
argument tuple: `front` (iterated newest first, where `+b` puts beliefs) and `back`
(iterated oldest first: initial beliefs and `+>b`). Lookup of a ground literal, adding
and removing are O(1); a query scans only its own predicate.
"""

from __future__ import annotations

import functools
from collections.abc import Iterator
from typing import Any

from mrss.agentspeak.terms import Struct, Term, compare, term_str
from mrss.agentspeak.unify import undo, unify_annots

Key = tuple[str, int, bool]


class Rule:
    """A rule `head :- body`, compiled: the body is a query run in a frame of `nslots`."""

    __slots__ = ("head", "body", "nslots", "line", "text", "seq", "src_body")

    def __init__(self, head: Struct, body: Any, nslots: int, line: int, text: str) -> None:
        self.head = head
        self.body = body
        self.nslots = nslots
        self.line = line
        self.text = text
        self.seq = 0  # its place among the facts at the end of its predicate (`born`)
        self.src_body: Any = None  # the body as a template, for `.relevant_rules`


NO_KEY = object()  # a first argument the first-argument index does not hold
INDEX_FROM = 16  # a predicate gets its first-argument index once it has this many facts


def first_key(t: Term) -> Any:
    """The first-argument index key of a (dereferenced) argument: a number, a string or
    an atom without annotations (equal keys are exactly the terms that unify), else
    NO_KEY."""
    tt = type(t)
    if tt is int or tt is float or tt is str:
        return t
    if tt is Struct and not t.args and not t.annots:  # type: ignore[union-attr]
        return t
    return NO_KEY


class PredStore:
    """The beliefs and rules of one predicate indicator.

    `first` indexes the facts by first argument (built when a query with a bound first
    argument meets a predicate of `INDEX_FROM` facts or more, then kept up to date):
    per key, the argument tuple of its one fact, or a dict of the argument tuples of
    its facts (in the order they were added, each mapped to whether it is in `front`);
    the facts themselves stay in `front` and `back`. `irregular` counts facts whose
    first argument has no key (then queries scan all facts, as such a fact may unify
    with anything)."""

    __slots__ = ("front", "back", "rules", "born", "seq", "first", "irregular")

    def __init__(self) -> None:
        self.front: dict[tuple[Term, ...], Struct] = {}
        self.back: dict[tuple[Term, ...], Struct] = {}
        self.rules: list[Rule] = []
        # facts at the end and rules share one program order: each gets the next `seq`
        # (only counted once the predicate has a rule, when the order matters)
        self.born: dict[tuple[Term, ...], int] = {}
        self.seq = 0
        self.first: dict[Any, Any] | None = None
        self.irregular = 0

    def facts_with_first(self, key: Any) -> Iterator[Struct] | None:
        """The facts whose first argument may unify with `key` (a `first_key`), in
        `facts()` order; None when the index cannot tell (then scan `facts()`)."""
        first = self.first
        if first is None:
            if len(self.front) + len(self.back) < INDEX_FROM:
                return None
            first = self._build_first()
        if self.irregular:
            return None
        entry = first.get(key)
        if entry is None:
            return iter(())
        if type(entry) is tuple:
            b = self.get(entry)
            return iter(() if b is None else (b,))
        return self._facts_in(entry)

    def _facts_in(self, entry: dict[tuple[Term, ...], bool]) -> Iterator[Struct]:
        front = self.front
        for args, in_front in reversed(entry.items()):
            if in_front:
                yield front[args]
        back = self.back
        for args, in_front in entry.items():
            if not in_front:
                yield back[args]

    def _build_first(self) -> dict[Any, Any]:
        self.first = {}
        self.irregular = 0
        for front, facts in ((True, self.front), (False, self.back)):
            for args in facts:
                self._index(args, front)
        return self.first

    def _index(self, args: tuple[Term, ...], front: bool) -> None:
        k = first_key(args[0])
        if k is NO_KEY:
            self.irregular += 1
            return
        first: dict[Any, Any] = self.first  # type: ignore[assignment]
        entry = first.get(k)
        if entry is None:
            first[k] = args
        elif type(entry) is tuple:
            first[k] = {entry: entry in self.front, args: front}
        else:
            entry[args] = front

    def _unindex(self, args: tuple[Term, ...]) -> None:
        k = first_key(args[0])
        if k is NO_KEY:
            self.irregular -= 1
            return
        first: dict[Any, Any] = self.first  # type: ignore[assignment]
        entry = first.get(k)
        if type(entry) is tuple:
            if entry == args:
                del first[k]
        elif entry is not None:
            entry.pop(args, None)
            if not entry:
                del first[k]

    def clauses(self) -> Iterator[Struct | Rule]:
        """Facts and rules in Jason's order: facts added in front (newest first), then
        the facts at the end and the rules, interleaved in the order they were added."""
        yield from reversed(list(self.front.values()))
        rules = self.rules
        born = self.born
        i = 0
        for args, b in list(self.back.items()):
            n = born.get(args, -1)
            while i < len(rules) and rules[i].seq < n:
                yield rules[i]
                i += 1
            yield b
        yield from rules[i:]

    def get(self, args: tuple[Term, ...]) -> Struct | None:
        b = self.front.get(args)
        return self.back.get(args) if b is None else b

    def facts(self) -> Iterator[Struct]:
        yield from reversed(self.front.values())
        yield from self.back.values()

    def __len__(self) -> int:
        return len(self.front) + len(self.back)

    def _add(self, args: tuple[Term, ...], lit: Struct, front: bool) -> None:
        """A new fact (no fact with these arguments is there)."""
        (self.front if front else self.back)[args] = lit
        if self.first is not None:
            self._index(args, front)

    def _put(self, args: tuple[Term, ...], lit: Struct) -> None:
        """Replace the fact with these arguments in its place (the index holds only
        the arguments: it stays as it is)."""
        if args in self.front:
            self.front[args] = lit
        else:
            self.back[args] = lit

    def _pop(self, args: tuple[Term, ...]) -> None:
        if self.first is not None and (args in self.front or args in self.back):
            self._unindex(args)
        if self.front.pop(args, None) is None:
            self.back.pop(args, None)
            if self.born:
                self.born.pop(args, None)


def _merge(old: tuple[Term, ...], new: tuple[Term, ...]) -> tuple[Term, ...] | None:
    """Annotations of `old` plus those of `new` it lacks, sorted; None if none is new."""
    extra = [a for a in new if a not in old]
    if not extra:
        return None
    merged = list(old) + extra
    if len(merged) > 1:
        merged.sort(key=functools.cmp_to_key(compare))
    return tuple(merged)


def has_source(annots: tuple[Term, ...]) -> bool:
    return any(type(a) is Struct and a.functor == "source" and len(a.args) == 1 for a in annots)


class BeliefBase:
    """All beliefs and rules of one agent."""

    def __init__(self) -> None:
        self.preds: dict[Key, PredStore] = {}
        self.size = 0

    def store(self, key: Key) -> PredStore | None:
        return self.preds.get(key)

    def _store(self, key: Key) -> PredStore:
        s = self.preds.get(key)
        if s is None:
            s = self.preds[key] = PredStore()
        return s

    def add(self, lit: Struct, front: bool = True, s: PredStore | None = None) -> bool:
        """Add `lit` (annotations merge into an existing equal belief); False if nothing
        new was added, in which case no event must be posted. `s`, when given, is the
        store of `lit`'s predicate (a body formula's, kept: `instructions.AddBelief`)."""
        if s is None:
            s = self._store((lit.functor, len(lit.args), lit.neg))
        args = lit.args
        old = s.front.get(args)
        if old is None:
            old = s.back.get(args)
        if old is None:  # a new fact (`PredStore._add`, inline)
            if front:
                s.front[args] = lit
            else:
                s.back[args] = lit
                if s.rules:
                    s.seq += 1
                    s.born[args] = s.seq
            if s.first is not None:
                s._index(args, front)
            self.size += 1
            return True
        merged = _merge(old.annots, lit.annots)
        if merged is None:
            return False
        s._put(args, Struct(old.functor, old.args, merged, old.neg))
        return True

    def remove(self, lit: Struct, s: PredStore | None = None) -> bool:
        """Remove the annotations of ground `lit` from the equal belief; the belief goes
        when no source is left. False when there was no such belief (not a failure).
        `s`, when given, is the store of `lit`'s predicate (`instructions.DelBelief`)."""
        if s is None:
            s = self.preds.get((lit.functor, len(lit.args), lit.neg))
            if s is None:
                return False
        args = lit.args
        in_front = True
        old = s.front.get(args)
        if old is None:
            in_front = False
            old = s.back.get(args)
            if old is None:
                return False
        if not lit.annots or lit.annots == old.annots:  # every annotation goes
            # `PredStore._pop`, inline
            if s.first is not None:
                s._unindex(args)
            if in_front:
                del s.front[args]
            else:
                del s.back[args]
                if s.born:
                    s.born.pop(args, None)
            self.size -= 1
            return True
        trail: list[Any] = []
        if not unify_annots(lit.annots, None, old.annots, trail):
            undo(trail, 0)
            return False
        undo(trail, 0)
        rest = tuple(a for a in old.annots if a not in lit.annots)
        if has_source(rest):
            s._put(lit.args, Struct(old.functor, old.args, rest, old.neg))
        else:
            s._pop(lit.args)
            self.size -= 1
        return True

    def abolish(self, key: Key, keep: Any = None) -> list[Struct]:
        """Remove every belief of predicate `key` for which `keep(b)` is false."""
        s = self.preds.get(key)
        if s is None:
            return []
        gone = [b for b in s.facts() if keep is None or not keep(b)]
        for b in gone:
            s._pop(b.args)
        self.size -= len(gone)
        return gone

    def add_rule(self, key: Key, rule: Rule) -> None:
        """Add a rule after the facts and rules of its predicate added so far."""
        s = self._store(key)
        if not s.rules:  # from now on the order of facts and rules matters
            s.born = {args: i for i, args in enumerate(s.back)}
            s.seq = len(s.back)
        s.seq += 1
        rule.seq = s.seq
        s.rules.append(rule)

    def remove_rule(self, head: Struct, rule: Rule) -> None:
        """Remove `rule` (of the predicate of `head`)."""
        s = self.preds.get((head.functor, len(head.args), head.neg))
        if s is not None and rule in s.rules:
            s.rules.remove(rule)

    def __iter__(self) -> Iterator[Struct]:
        for s in self.preds.values():
            yield from s.facts()

    def texts(self) -> list[str]:
        """Every belief and rule as Jason prints it, in belief-base order."""
        out: list[str] = []
        for s in self.preds.values():
            out.extend(c.text if type(c) is Rule else term_str(c)  # type: ignore[arg-type]
                       for c in (s.clauses() if s.rules else s.facts()))
        return out
