"""Which internal actions and functions a run of AgentSpeak programs executes, counted
as they are called (not searched for in the programs' text)."""

from __future__ import annotations

import functools
from collections import Counter
from collections.abc import Callable, Iterator
from contextlib import contextmanager
from typing import Any

import pytest

from mrss.agentspeak import arith, functions
from mrss.agentspeak.registry import IAContext, IAResult, Registry


def counting(registry: Registry, counts: Counter[str]) -> Registry:
    """`registry` with every internal action counting its calls in `counts` (each one
    registered again in `registry`: give a child, or a registry of one run)."""
    for name in registry.names():
        ia = registry.get(name)
        assert ia is not None

        def counted(ctx: IAContext, args: list[Any], *, _name: str = name,
                    _fn: Callable[[IAContext, list[Any]], IAResult] = ia.fn) -> IAResult:
            counts[_name] += 1
            return _fn(ctx, args)

        registry.register(name, counted, min_args=ia.min_args, max_args=ia.max_args,
                          formula_args=tuple(ia.formula_args), body_only=ia.body_only,
                          raw_args=tuple(ia.raw_args))
    return registry


@contextmanager
def counting_functions(monkeypatch: pytest.MonkeyPatch, counts: Counter[str]
                       ) -> Iterator[None]:
    """While inside: every arithmetic function (`math.abs`, ...) and term function
    (`.length`, `math.sum`, `.count`, ...) that runs is counted in `counts`."""
    def wrap(name: str, fn: Callable[..., Any]) -> Callable[..., Any]:
        @functools.wraps(fn)
        def counted(*args: Any, **kwargs: Any) -> Any:
            counts[name] += 1
            return fn(*args, **kwargs)
        return counted

    with monkeypatch.context() as patch:
        for name, fn in list(arith.FUNCTIONS.items()):
            patch.setitem(arith.FUNCTIONS, name, wrap(name, fn))
        for name, fn in list(functions._PURE.items()):
            patch.setitem(functions._PURE, name, wrap(name, fn))
        make_count = functions._count_call
        patch.setattr(functions, "_count_call", lambda env, query: wrap(
            ".count", make_count(env, query)))
        yield
