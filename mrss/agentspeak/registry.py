"""Internal actions: the registry mapping `.name` to Python code, and the call context.

An internal action is a function `fn(ctx, args) -> result` where `args` are the
resolved arguments (free variables appear as `Var`s that `ctx.unify` may bind; the
positions listed in `formula_args` hold compiled queries instead). The result is
`None`/`True` (success), `False` (failure: the intention fails with `ia_failed`), or an
iterator yielding once per solution (for backtracking use in plan contexts).
Projects add their own with `registry.register(".my_action", fn)`.
"""

from __future__ import annotations

from collections.abc import Callable, Iterator
from dataclasses import dataclass
from typing import TYPE_CHECKING, Any

from mrss.agentspeak.errors import AslRuntimeError
from mrss.agentspeak.terms import Term, term_str, value
from mrss.agentspeak.unify import resolve, undo, unify

if TYPE_CHECKING:
    from mrss.agentspeak.intentions import IntendedMeans, Intention
    from mrss.agentspeak.runtime import Runtime

IAResult = bool | None | Iterator[Any]
IAFunction = Callable[["IAContext", list[Any]], IAResult]


@dataclass(frozen=True)
class InternalAction:
    """A registered internal action and how to call it."""

    name: str
    fn: IAFunction
    min_args: int = 0
    max_args: int | None = None
    formula_args: frozenset[int] = frozenset()
    body_only: bool = False  # e.g. .wait: meaningless in a plan context
    raw_args: frozenset[int] = frozenset()  # passed unresolved: use ctx.resolve per use


class Registry:
    """Name -> internal action; a child registry falls back to its parent."""

    def __init__(self, parent: Registry | None = None) -> None:
        self._actions: dict[str, InternalAction] = {}
        self._parent = parent

    def register(self, name: str, fn: IAFunction, *, min_args: int = 0,
                 max_args: int | None = None, formula_args: tuple[int, ...] = (),
                 body_only: bool = False, raw_args: tuple[int, ...] = ()) -> InternalAction:
        """Add (or replace) internal action `name` (it must start with a dot)."""
        if not name.startswith("."):
            raise ValueError(f"internal action names start with a dot: {name!r}")
        ia = InternalAction(name, fn, min_args, max_args, frozenset(formula_args), body_only,
                            frozenset(raw_args))
        self._actions[name] = ia
        return ia

    def action(self, name: str, **options: Any) -> Callable[[IAFunction], IAFunction]:
        """Decorator form of `register`."""
        def wrap(fn: IAFunction) -> IAFunction:
            self.register(name, fn, **options)
            return fn
        return wrap

    def get(self, name: str) -> InternalAction | None:
        ia = self._actions.get(name)
        if ia is None and self._parent is not None:
            return self._parent.get(name)
        return ia

    def child(self) -> Registry:
        """A registry with everything of this one, to which a project adds its own."""
        return Registry(self)

    def names(self) -> list[str]:
        names = set(self._actions)
        if self._parent is not None:
            names.update(self._parent.names())
        return sorted(names)


class IAContext:
    """What an internal action sees: the agent runtime, the intention and frame."""

    __slots__ = ("runtime", "intention", "im", "frame", "name")

    def __init__(self, runtime: Runtime, intention: Intention | None,
                 im: IntendedMeans | None, frame: list[Any] | None, name: str) -> None:
        self.runtime = runtime
        self.intention = intention
        self.im = im
        self.frame = frame
        self.name = name

    def unify(self, a: Term, b: Term) -> bool:
        """Unify two runtime terms, binding free variables; no bindings on failure."""
        trail = self.runtime.trail
        mark = len(trail)
        if unify(a, None, b, trail):
            return True
        undo(trail, mark)
        return False

    def solve(self, query: Any) -> Iterator[None]:
        """Solutions of a compiled query (or formula term), bindings in place per solution."""
        from mrss.agentspeak.formulas import Query, compile_query

        q = query if isinstance(query, Query) else compile_query(query, self.runtime.registry)
        return q.solve(self.runtime, self.frame)

    def resolve(self, template: Term) -> Term:
        """The current value of an argument passed unresolved (`raw_args`)."""
        return value(resolve(template, self.frame))

    def error(self, message: str) -> AslRuntimeError:
        """An error to raise for bad arguments: fails the intention with `ia_failed`."""
        return AslRuntimeError(f"{self.name}: {message}")

    def text(self, t: Term) -> str:
        return term_str(t)
