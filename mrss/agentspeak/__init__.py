"""A Jason-compatible AgentSpeak(L) interpreter: the reasoner core of MRSS.

`Agent` runs one agent (see docs/agentspeak.md); `Registry` holds internal actions.

The names below are imported from their modules when first used (PEP 562): a process
that only reads a literal (`parse_literal`, `Struct`, `Var`; the root supervisor reading
project.toml) does not import the interpreter and its parser.
"""

from __future__ import annotations

import importlib
from typing import TYPE_CHECKING, Any

if TYPE_CHECKING:
    from mrss.agentspeak.agent import Agent, default_registry
    from mrss.agentspeak.errors import AslRuntimeError, AslSyntaxError, SyntaxProblem
    from mrss.agentspeak.host import ConsoleHost, run_standalone
    from mrss.agentspeak.hostactions import Host
    from mrss.agentspeak.parser import parse_literal, parse_term
    from mrss.agentspeak.registry import IAContext, Registry
    from mrss.agentspeak.terms import Struct, Var, term_str

_WHERE = {
    "Agent": "agent", "default_registry": "agent",
    "AslRuntimeError": "errors", "AslSyntaxError": "errors", "SyntaxProblem": "errors",
    "ConsoleHost": "host", "run_standalone": "host", "Host": "hostactions",
    "parse_literal": "parser", "parse_term": "parser",
    "IAContext": "registry", "Registry": "registry",
    "Struct": "terms", "Var": "terms", "term_str": "terms",
}

__all__ = [
    "Agent", "AslRuntimeError", "AslSyntaxError", "ConsoleHost", "Host", "IAContext",
    "Registry", "Struct", "SyntaxProblem", "Var", "default_registry", "parse_literal",
    "parse_term", "run_standalone", "term_str",
]
assert sorted(__all__) == sorted(_WHERE)


def __getattr__(name: str) -> Any:
    module = _WHERE.get(name)
    if module is None:
        raise AttributeError(f"module {__name__!r} has no attribute {name!r}")
    value = getattr(importlib.import_module(f"{__name__}.{module}"), name)
    globals()[name] = value
    return value


def __dir__() -> list[str]:
    return sorted([*globals(), *_WHERE])
