"""A Jason-compatible AgentSpeak(L) interpreter: the reasoner core of MRSS.

`Agent` runs one agent (see docs/agentspeak.md); `Registry` holds internal actions.
"""

from __future__ import annotations

from mrss.agentspeak.agent import Agent, default_registry
from mrss.agentspeak.errors import AslRuntimeError, AslSyntaxError, SyntaxProblem
from mrss.agentspeak.host import ConsoleHost, run_standalone
from mrss.agentspeak.hostactions import Host
from mrss.agentspeak.parser import parse_literal, parse_term
from mrss.agentspeak.registry import IAContext, Registry
from mrss.agentspeak.terms import Struct, Var, term_str

__all__ = [
    "Agent", "AslRuntimeError", "AslSyntaxError", "ConsoleHost", "Host", "IAContext",
    "Registry", "Struct", "SyntaxProblem", "Var", "default_registry", "parse_literal",
    "parse_term", "run_standalone", "term_str",
]
