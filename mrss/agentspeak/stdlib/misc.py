"""Printing, time, names, belief-base and failure internal actions."""

from __future__ import annotations

import datetime
import enum
import functools
import time as _time
from collections.abc import Iterator
from typing import Any

from mrss.agentspeak.errors import AslRuntimeError
from mrss.agentspeak.jrandom import RNG
from mrss.agentspeak.registry import IAContext
from mrss.agentspeak.stdlib import STDLIB
from mrss.agentspeak.terms import (
    DEL_BEL,
    Struct,
    Term,
    Var,
    VarAnnot,
    compare,
    deref,
    term_str,
    value,
)
from mrss.agentspeak.unify import undo, unify

_order = functools.cmp_to_key(compare)


def text_of(t: Term) -> str:
    """How `.print` and `.concat` show a term: strings without quotes."""
    return term_str(value(t), top=True)


@STDLIB.action(".print")
def print_(ctx: IAContext, args: list[Any]) -> bool:
    """Print the arguments concatenated, no separator, one line per call."""
    ctx.runtime.out("".join(text_of(a) for a in args))
    return True


class LogLevel(enum.Enum):
    """The levels of `.log` (java.util.logging's); Jason's default console shows INFO
    and above."""

    SEVERE = "severe"
    WARNING = "warning"
    INFO = "info"
    FINE = "fine"
    FINER = "finer"
    FINEST = "finest"


_SHOWN = {LogLevel.SEVERE, LogLevel.WARNING, LogLevel.INFO}


@STDLIB.action(".log", min_args=1)
def log_(ctx: IAContext, args: list[Any]) -> bool:
    """`.log(Level, Args...)`: like `.print` at severe, warning and info (any other
    atom counts as info, as in Jason); fine, finer and finest are not shown."""
    level = deref(args[0])
    if type(level) is not Struct or level.args or level.annots or level.neg:
        raise ctx.error(f"the level must be an atom (severe, warning, info, fine, finer or "
                        f"finest), not {term_str(level)}")
    known = {lv.value: lv for lv in LogLevel}
    if known.get(level.functor, LogLevel.INFO) in _SHOWN:
        ctx.runtime.out("".join(text_of(a) + ("<no-value>" if type(deref(a)) is Var else "")
                                for a in args[1:]))
    return True


@STDLIB.action(".println")
def println(ctx: IAContext, args: list[Any]) -> bool:
    ctx.runtime.out("".join(text_of(a) for a in args))
    return True


@STDLIB.action(".my_name", min_args=1, max_args=1)
def my_name(ctx: IAContext, args: list[Any]) -> bool:
    return ctx.unify(args[0], Struct(ctx.runtime.name))


@STDLIB.action(".time", min_args=3, max_args=4)
def time_(ctx: IAContext, args: list[Any]) -> bool:
    """`.time(H, M, S[, MS])`: the current local time."""
    now = datetime.datetime.now()
    parts = [now.hour, now.minute, now.second, now.microsecond // 1000]
    return all(ctx.unify(a, v) for a, v in zip(args, parts, strict=False))


@STDLIB.action(".date", min_args=3, max_args=3)
def date_(ctx: IAContext, args: list[Any]) -> bool:
    """`.date(Y, M, D)`: today's date."""
    today = datetime.date.today()
    return all(ctx.unify(a, v) for a, v in zip(args, (today.year, today.month, today.day),
                                                  strict=True))


@STDLIB.action(".random", min_args=1, max_args=3)
def random_(ctx: IAContext, args: list[Any]) -> Iterator[None]:
    """As Jason's random.java: `.random(X)`, X a number in [0, 1); `.random(X, N)`, N
    such numbers in turn (0: without end, for backtracking); `.random(L, X)` and
    `.random(L, X, N)`, X an item of list L picked at random (once, or N times)."""
    first = deref(args[0])
    items: tuple[Term, ...] | None = None
    if type(first) is tuple:
        if len(args) == 1:
            raise ctx.error("a list needs the variable to bind: .random(L, X)")
        items, target, count = first, args[1], (args[2] if len(args) == 3 else 1)
        if not items:
            return
    elif len(args) == 3:
        raise ctx.error(f"expected a list, not {term_str(first)}")
    else:
        target, count = args[0], (args[1] if len(args) == 2 else 1)
    n = deref(count)
    if type(n) is not int or n < 0:
        raise ctx.error(f"the number of values must be a natural number, not "
                        f"{term_str(n)}")
    trail = ctx.runtime.trail
    drawn = 0
    while n == 0 or drawn < n:
        drawn += 1
        mark = len(trail)
        pick = RNG.random() if items is None else items[RNG.next_int(len(items))]
        if ctx.unify(target, pick):
            yield
        undo(trail, mark)


@STDLIB.action(".set_random_seed", min_args=1, max_args=1)
def set_random_seed(ctx: IAContext, args: list[Any]) -> bool:
    """`.set_random_seed(N)`: `.random` and `.shuffle` repeat the same numbers after it."""
    n = deref(args[0])
    if type(n) is not int:
        raise ctx.error(f"the seed must be an integer, not {term_str(n)}")
    RNG.seed(n)
    return True


@STDLIB.action(".nano_time", min_args=1, max_args=1)
def nano_time(ctx: IAContext, args: list[Any]) -> bool:
    return ctx.unify(args[0], _time.perf_counter_ns())


@STDLIB.action(".fail")
def fail(ctx: IAContext, args: list[Any]) -> bool:
    """Fail the current plan; arguments become annotations of the `-!g` event."""
    annots = tuple(args)
    error = "ia_failed"
    for a in annots:
        if type(a) is Struct and a.functor == "error" and len(a.args) == 1 \
                and type(a.args[0]) is Struct:
            error = a.args[0].functor
    raise AslRuntimeError(".fail", error=error,
                          annots=tuple(a for a in annots
                                       if not (type(a) is Struct and a.functor == "error")))


@STDLIB.action(".abolish", min_args=1, max_args=1)
def abolish(ctx: IAContext, args: list[Any]) -> bool:
    """Remove every belief that unifies with the argument (posting `-b` events); a
    variable with annotations (`_[source(ag2)]`) looks at every belief, as Jason's
    Agent.abolish does for a variable."""
    pattern = deref(args[0])
    if type(pattern) is not Struct and type(pattern) is not VarAnnot:
        raise ctx.error(f"expected a literal, not {term_str(pattern)}")
    rt = ctx.runtime
    trail = rt.trail

    def matches(b: Struct) -> bool:
        mark = len(trail)
        ok = unify(pattern, None, b, trail)
        undo(trail, mark)
        return ok

    keys = [pattern.key] if type(pattern) is Struct else list(rt.bb.preds)
    for key in keys:
        for b in rt.bb.abolish(key, keep=lambda b: not matches(b)):
            rt.belief_changed(DEL_BEL, b, None)
    return True


@STDLIB.action(".findall", min_args=3, max_args=3, formula_args=(1,), raw_args=(0,))
def findall(ctx: IAContext, args: list[Any]) -> bool:
    """`.findall(T, Query, L)`: L is the list of T for every solution of Query."""
    template, query, out = args
    found = tuple(ctx.resolve(template) for _ in ctx.solve(query))
    return ctx.unify(out, found)


@STDLIB.action(".setof", min_args=3, max_args=3, formula_args=(1,), raw_args=(0,))
def setof(ctx: IAContext, args: list[Any]) -> bool:
    """`.setof(T, Query, L)`: like `.findall`, sorted in the standard order, each once."""
    template, query, out = args
    found = sorted((ctx.resolve(template) for _ in ctx.solve(query)), key=_order)
    unique = [t for i, t in enumerate(found) if i == 0 or compare(found[i - 1], t) != 0]
    return ctx.unify(out, tuple(unique))


@STDLIB.action(".count", min_args=2, max_args=2, formula_args=(0,))
def count(ctx: IAContext, args: list[Any]) -> bool:
    """`.count(Query, N)`: N is the number of solutions of Query."""
    n = sum(1 for _ in ctx.solve(args[0]))
    return ctx.unify(args[1], n)


def string_arg(ctx: IAContext, t: Term) -> str:
    t = deref(t)
    if type(t) is str:
        return t
    if type(t) is Var:
        raise ctx.error(f"unbound variable {term_str(t)}")
    return text_of(t)


@STDLIB.action(".concat", min_args=3)
def concat(ctx: IAContext, args: list[Any]) -> bool:
    """Concatenate lists (all arguments but the last are lists) or strings."""
    parts = [deref(a) for a in args[:-1]]
    if all(type(p) is tuple for p in parts):
        return ctx.unify(args[-1], tuple(x for p in parts for x in p))  # type: ignore[union-attr]
    return ctx.unify(args[-1], "".join(string_arg(ctx, p) for p in parts))


@STDLIB.action(".substring", min_args=2, max_args=4)
def substring(ctx: IAContext, args: list[Any]) -> Iterator[None]:
    """`.substring(S, T[, Pos])`: S occurs in T (at each position Pos, on backtracking).
    As Jason 3.1 (stdlib/substring.java): `.substring(X, T, Start[, End])` with X free
    gives X the text of T from Start to End (T's end by default), and with T free
    (`.substring("a(10,20)", X, 5, 7)`, kept by Jason for compatibility) the other way
    round. Otherwise every position Pos of S in T, and End, when given, is unified
    with Pos + length(S) - 1 (the index of the match's last character: Jason's
    `(pos-2)+s0.length()` after its `pos++`)."""
    first, second = deref(args[0]), deref(args[1])
    start_at = deref(args[2]) if len(args) > 2 else None
    if type(start_at) in (int, float) and (type(first) is Var or type(second) is Var):
        out, text = (args[0], string_arg(ctx, second)) if type(first) is Var else \
            (args[1], string_arg(ctx, first))
        end = deref(args[3]) if len(args) > 3 else None
        begin = int(start_at)  # type: ignore[arg-type]
        stop = int(end) if type(end) in (int, float) else len(text)  # type: ignore[arg-type]
        if not 0 <= begin <= stop <= len(text):
            raise ctx.error(f"no text from {begin} to {stop} in {text!r}")
        if ctx.unify(out, text[begin:stop]):
            yield
        return
    sub = string_arg(ctx, args[0])
    whole = string_arg(ctx, args[1])
    trail = ctx.runtime.trail
    start = whole.find(sub)
    while start >= 0:
        mark = len(trail)
        if len(args) < 3 or (ctx.unify(args[2], start)
                             and (len(args) < 4 or ctx.unify(args[3], start + len(sub) - 1))):
            yield
        undo(trail, mark)
        start = whole.find(sub, start + 1)


@STDLIB.action(".eval", min_args=2, max_args=2, formula_args=(1,))
def eval_(ctx: IAContext, args: list[Any]) -> bool:
    """`.eval(R, Formula)`: R is `true` if the formula holds (no bindings are kept),
    else `false`."""
    trail = ctx.runtime.trail
    mark = len(trail)
    holds = False
    for _ in ctx.solve(args[1]):
        holds = True
        break
    undo(trail, mark)
    return ctx.unify(args[0], Struct("true" if holds else "false"))


@STDLIB.action(".belief", min_args=1, max_args=1)
def belief(ctx: IAContext, args: list[Any]) -> Iterator[None]:
    """`.belief(L)`: L unifies with each belief in turn (facts only, no rules)."""
    pattern = deref(args[0])
    if type(pattern) is not Struct:
        raise ctx.error(f"expected a literal, not {term_str(pattern)}")
    store = ctx.runtime.bb.store(pattern.key)
    trail = ctx.runtime.trail
    for b in list(store.facts()) if store is not None else []:
        mark = len(trail)
        if unify(pattern, None, b, trail):
            yield
        undo(trail, mark)


@STDLIB.action(".list_rules", max_args=0)
def list_rules(ctx: IAContext, args: list[Any]) -> bool:
    """Print every rule of the belief base, one per line, in program order."""
    for store in list(ctx.runtime.bb.preds.values()):
        for rule in store.rules:
            ctx.runtime.out(rule.text + ".")
    return True


VERSION = "3.2"  # the version of Jason's language this interpreter follows


@STDLIB.action(".version", min_args=1, max_args=1)
def version(ctx: IAContext, args: list[Any]) -> bool:
    """`.version(V)`: V is the version of Jason's language followed, as a string."""
    return ctx.unify(args[0], VERSION)


@STDLIB.action(".perceive", max_args=0)
def perceive(ctx: IAContext, args: list[Any]) -> bool:
    """Percepts are applied at the start of every cycle, so there is nothing to force:
    succeeds (Jason's `.perceive` forces a perception now)."""
    return True


def _namespaces(ctx: IAContext) -> list[str]:
    rt = ctx.runtime
    found = {"default"}
    for functor, _, _ in list(rt.bb.preds):
        if "::" in functor:
            found.add(functor.split("::", 1)[0])
    found.update(rt.extras.ns_props)
    for plan in list(rt.plans.plans):
        if "::" in plan.trigger.functor:
            found.add(plan.trigger.functor.split("::", 1)[0])
    return sorted(found)


@STDLIB.action(".namespace", min_args=1, max_args=1)
def namespace(ctx: IAContext, args: list[Any]) -> Iterator[None]:
    """`.namespace(N)`: N is a namespace the agent's beliefs or plans use (`default`
    included), each in turn."""
    trail = ctx.runtime.trail
    for name in _namespaces(ctx):
        mark = len(trail)
        if ctx.unify(args[0], Struct(name)):
            yield
        undo(trail, mark)


def _ns_props(ctx: IAContext, ns: Term) -> dict[str, tuple[Term, Term]]:
    ns = deref(ns)
    if type(ns) is not Struct or ns.args:
        raise ctx.error(f"the namespace must be an atom, not {term_str(ns)}")
    return ctx.runtime.extras.ns_props.setdefault(ns.functor, {})


@STDLIB.action(".namespace_set_prop", min_args=3, max_args=3)
def namespace_set_prop(ctx: IAContext, args: list[Any]) -> bool:
    """`.namespace_set_prop(NS, Key, Value)`: a property of namespace NS."""
    key = value(args[1])
    if type(key) is Var:
        raise ctx.error("the key is an unbound variable")
    _ns_props(ctx, args[0])[term_str(key)] = (key, value(args[2]))
    return True


@STDLIB.action(".namespace_get_prop", min_args=2, max_args=4)
def namespace_get_prop(ctx: IAContext, args: list[Any]) -> Iterator[None]:
    """`.namespace_get_prop(NS, Key, Value[, Default])`: the property (Default when
    it has none); `.namespace_get_prop(NS, Key)` enumerates the keys, in the order set."""
    props = _ns_props(ctx, args[0])
    trail = ctx.runtime.trail
    if len(args) == 4 and type(value(args[1])) is not Var \
            and term_str(value(args[1])) not in props:
        if ctx.unify(args[2], value(args[3])):
            yield
        return
    for key, val in list(props.values()):
        mark = len(trail)
        if ctx.unify(args[1], key) and (len(args) == 2 or ctx.unify(args[2], val)):
            yield
        undo(trail, mark)
