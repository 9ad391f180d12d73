"""The directory facilitator of a society (Jason's DF): agents register the services
they provide and find, or subscribe to, the providers of a service.

- `.df_register(S)`, `.df_register(S, T)`: this agent provides service S (of type T);
- `.df_deregister(S)`, `.df_deregister(S, T)`: it no longer does;
- `.df_search(S, L)`, `.df_search(S, T, L)`: L lists the providers of S (of type T),
  in the order they registered;
- `.df_subscribe(S)`, `.df_subscribe(S, T)`: this agent is told
  `provider(Agent, S)[source(df)]` for each provider of S, now and as they register.
"""

from __future__ import annotations

from collections.abc import Callable
from typing import Any

from mrss.agentspeak.registry import IAContext, Registry
from mrss.agentspeak.terms import Struct, Term, Var, term_str, value

Service = tuple[str, str]  # (service, type); the type "" when none is given
DF_NAME = "df"


class Directory:
    """Providers and subscribers by service; `tell(receiver, literal)` delivers a
    `tell` from the DF to an agent of the society."""

    def __init__(self, tell: Callable[[str, Struct], object]) -> None:
        self.providers: dict[Service, list[str]] = {}
        self.subscribers: dict[Service, list[str]] = {}
        self.terms: dict[str, Term] = {}  # a service's text -> the service as given
        self._tell = tell

    def register(self, registry: Registry) -> None:
        registry.register(".df_register", self._register, min_args=1, max_args=2)
        registry.register(".df_deregister", self._deregister, min_args=1, max_args=2)
        registry.register(".df_search", self._search, min_args=2, max_args=3)
        registry.register(".df_subscribe", self._subscribe, min_args=1, max_args=2)

    @staticmethod
    def _text(ctx: IAContext, t: Term, what: str) -> str:
        t = value(t)
        if type(t) is Var:
            raise ctx.error(f"the {what} is an unbound variable")
        return t if type(t) is str else term_str(t)

    def _service(self, ctx: IAContext, args: list[Any]) -> Service:
        kind = self._text(ctx, args[1], "type") if len(args) > 1 else ""
        name = self._text(ctx, args[0], "service")
        self.terms.setdefault(name, value(args[0]))
        return name, kind

    def _provider(self, agent: str, service: str) -> Struct:
        return Struct("provider", (Struct(agent), self.terms.get(service, service)))

    def _matching(self, service: Service) -> list[Service]:
        name, kind = service
        return [s for s in self.providers if s[0] == name and (not kind or s[1] == kind)]

    def _notify(self, service: Service, agent: str) -> None:
        for (name, kind), subscribers in self.subscribers.items():
            if name == service[0] and (not kind or kind == service[1]):
                for sub in subscribers:
                    self._tell(sub, self._provider(agent, service[0]))

    def _register(self, ctx: IAContext, args: list[Any]) -> bool:
        service = self._service(ctx, args)
        providers = self.providers.setdefault(service, [])
        me = ctx.runtime.name
        if me not in providers:
            providers.append(me)
            self._notify(service, me)
        return True

    def _deregister(self, ctx: IAContext, args: list[Any]) -> bool:
        me = ctx.runtime.name
        for service in self._matching(self._service(ctx, args)):
            if me in self.providers[service]:
                self.providers[service].remove(me)
        return True

    def _search(self, ctx: IAContext, args: list[Any]) -> bool:
        service = self._service(ctx, args[:-1])
        found: list[str] = []
        for s in self._matching(service):
            found += [a for a in self.providers[s] if a not in found]
        return ctx.unify(args[-1], tuple(Struct(a) for a in found))

    def _subscribe(self, ctx: IAContext, args: list[Any]) -> bool:
        service = self._service(ctx, args)
        subscribers = self.subscribers.setdefault(service, [])
        me = ctx.runtime.name
        if me not in subscribers:
            subscribers.append(me)
            for s in self._matching(service):
                for agent in self.providers[s]:
                    self._tell(me, self._provider(agent, s[0]))
        return True
