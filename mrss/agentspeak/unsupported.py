"""Jason's standard internal actions this interpreter leaves out, each with the reason.

Everything else of Jason 3's standard library is implemented (see docs/agentspeak.md).
A program naming one of these is refused when it loads, at file:line:col, with
"`.name` is not supported: reason"; so is a plan added at run time.
"""

from __future__ import annotations

_AGENTS = ("agents are started and stopped by MRSS's supervisor and configuration, "
           "not by Jason's MAS infrastructure")
_JAVA = ("{kind} hold a mutable Java object (an ObjectTerm) that AgentSpeak terms here "
         "cannot; use lists (.member, .union, .sort, ...)")
_CONTROL = "it is the implementation of {syntax}; write {syntax} in the plan body"

UNSUPPORTED: dict[str, str] = {
    ".create_agent": _AGENTS, ".kill_agent": _AGENTS, ".clone": _AGENTS,
    ".save_agent": _AGENTS, ".stopMAS": _AGENTS,
    ".fork": "fork and join (|&| and |||) are not supported",
    ".join": "fork and join (|&| and |||) are not supported",
    ".if_then_else": _CONTROL.format(syntax="if (...) { ... }"),
    ".loop": _CONTROL.format(syntax="while (...) { ... }"),
    ".foreach": _CONTROL.format(syntax="for (...) { ... }"),
    ".signal": "signals come from a Java environment (CArtAgO artifacts), which MRSS "
               "does not have",
    ".verbose": "the log level is set by MRSS's logging configuration (logger "
                "mrss.agentspeak), not by the agent",
}
_PREFIXES = {".set.": _JAVA.format(kind="Java sets"),
             ".queue.": _JAVA.format(kind="Java queues"),
             ".map.": _JAVA.format(kind="Java maps")}
# only in a society of agents (`mrss agent a.asl b.asl`, or the reasoner's `agents`)
SOCIETY_ONLY = (".send", ".broadcast", ".all_names", ".df_register", ".df_deregister",
                ".df_search", ".df_subscribe")
_SOCIETY = ("it needs other agents: run several (mrss agent a.asl b.asl, or the "
            "reasoner component's agents list)")


def why_unsupported(name: str) -> str | None:
    """The reason internal action `name` is not supported, or None if it is not one of
    Jason's."""
    why = UNSUPPORTED.get(name)
    if why is None:
        for prefix, reason in _PREFIXES.items():
            if name.startswith(prefix):
                return reason
    if why is None and name in SOCIETY_ONLY:
        return _SOCIETY
    return why


def unknown_action_message(name: str) -> str:
    """The error for an internal action that is not in the registry."""
    why = why_unsupported(name)
    return f"`{name}` is not supported: {why}" if why else f"unknown internal action {name}"
