"""What each operator role may do: the one table of permissions, as data.

An operator has one role. A role allows a set of command kinds; a project's own
operator command (`[operator.commands.NAME] role`) names the least role that may send
it, and the commands of the fixed vocabulary (`area`, `cancel`, `priority`, `teleop`,
`hold`) need `operator`. The component that executes a command checks it
(`mrss.runtime.operator_guard`), never only the dashboard.
"""

from __future__ import annotations

from enum import StrEnum


class Role(StrEnum):
    """An operator's role, from least to most allowed."""

    OBSERVER = "observer"  # watches: read-only
    OPERATOR = "operator"  # steers the mission
    COMMANDER = "commander"  # also stops the system, injects faults, commander-only commands

    @property
    def rank(self) -> int:
        return list(Role).index(self)


class CommandKind(StrEnum):
    """The kinds of operator command a component executes (on the bus, MQTT or HTTP)."""

    READ = "read"  # snapshots and polls (ctl.tree, ctl.mind, ctl.snapshot), world model reads
    PERCEPT = "percept"  # a percept typed on the percept line (ctl.percept / percept)
    MISSION = "mission"  # the project's operator commands (area, cancel, declared forms)
    ANSWER = "answer"  # an answer to the agent's question (`.ask_operator`)
    ACTION_CONTROL = "action_control"  # debug keys: cancel / suspend / resume one action
    TELEOP = "teleop"  # ctl.teleop
    DECOMMISSION = "decommission"  # ctl.decommission / ctl.recommission
    STAND_DOWN = "stand_down"  # ctl.stand_down / ctl.stand_down_lift: robots in an area hold
    WORLD_WRITE = "world_write"  # world model HTTP POST / PUT / DELETE
    FAULT = "fault"  # ctl.fault
    STOP = "stop"  # ctl.stop: the whole system


#: role -> the command kinds it may send. The one place permissions are declared.
PERMISSIONS: dict[Role, frozenset[CommandKind]] = {
    Role.OBSERVER: frozenset({CommandKind.READ}),
    Role.OPERATOR: frozenset({CommandKind.READ, CommandKind.PERCEPT, CommandKind.MISSION,
                              CommandKind.ANSWER, CommandKind.ACTION_CONTROL,
                              CommandKind.TELEOP, CommandKind.WORLD_WRITE,
                              CommandKind.STAND_DOWN}),
    Role.COMMANDER: frozenset(CommandKind),
}


#: The bus commands (`Command.command` on `ctl.<command>`) that change something, by kind.
BUS_COMMANDS: dict[str, CommandKind] = {
    "teleop": CommandKind.TELEOP, "decommission": CommandKind.DECOMMISSION,
    "recommission": CommandKind.DECOMMISSION, "fault": CommandKind.FAULT,
    "stop": CommandKind.STOP, "stand_down": CommandKind.STAND_DOWN,
    "stand_down_lift": CommandKind.STAND_DOWN,
}


def refusal(role: Role, kind: CommandKind, least: Role | None = None) -> str:
    """Why `role` may not send a command of `kind` (whose own least role is `least`),
    or "" when it may."""
    if kind not in PERMISSIONS[role]:
        allowed = [r.value for r in Role if kind in PERMISSIONS[r]]
        return (f"the {role.value} role may not send {kind.value} commands (only "
                f"{', '.join(allowed)})")
    if least is not None and role.rank < least.rank:
        return f"the {role.value} role may not send it (it needs {least.value})"
    return ""
