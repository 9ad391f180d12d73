"""The reasoner's translation between AgentSpeak actions and the RCL's messages; pure.

- an environment action literal becomes an `ActionRequest` (`action_request`): a new
  uuid, its arguments as plain JSON-like values (`plain_arg`: structures as their
  text), robot and goal its first two, its `priority(P)` annotation;
- an action whose first argument is a role, `any(Capabilities)` or
  `any(Capabilities, at(Lat, Lon))`, goes with no robot and that role
  (`ActionRequest.role`, mrss.messages.roles): the RCL awards it to a robot;
- `rcl_goal_management(Command, Target)` (or `(Command, Kind, Target)`) becomes an
  `ActionControl` (`goal_management_control`);
- a failed or cancelled `ActionStatus` becomes the `error(E)` its plan sees
  (`failure_error`): the RCL's `FailureCause`, or Jason's `action_failed`.
"""

from __future__ import annotations

import uuid as uuidlib
from typing import Any

from mrss.agentspeak import Struct, term_str
from mrss.agentspeak.terms import PList
from mrss.errors import MrssError
from mrss.messages import (
    CONTROL_COMMANDS,
    CONTROL_TARGETS,
    ActionControl,
    ActionRequest,
    ActionState,
    ActionStatus,
    ControlCommand,
    ControlTarget,
    FailureCause,
)
from mrss.messages.roles import CAPABILITIES, NEAR, PLACE_FUNCTOR, ROLE_FUNCTOR

GOAL_MANAGEMENT = "rcl_goal_management"
ACTION_FAILED = "action_failed"  # Jason's error for a failed action of no known cause


def failure_error(status: ActionStatus) -> str:
    """The `error(E)` a failed or cancelled action gives its plan."""
    if status.cause:
        return status.cause
    if status.state == ActionState.CANCELLED.value:
        return FailureCause.CANCELLED.value
    return ACTION_FAILED


def plain_arg(t: Any) -> Any:
    """An action argument as a JSON-like value for the RCL (structures as their text)."""
    if isinstance(t, bool):
        return t
    if isinstance(t, (int, float, str)):
        return t
    if isinstance(t, tuple):
        return [plain_arg(x) for x in t]
    if isinstance(t, PList):
        return term_str(t)
    if isinstance(t, Struct) and not t.args and not t.annots and not t.neg:
        return t.functor
    return term_str(t)


def _annotation(action: Struct, name: str) -> Any:
    for a in action.annots:
        if isinstance(a, Struct) and a.functor == name and len(a.args) == 1:
            return a.args[0]
    return None


def action_request(action: Struct) -> ActionRequest:
    """The ActionRequest of an environment action, under a new uuid (MrssError: a
    malformed role)."""
    args = [plain_arg(a) for a in action.args]
    priority = _annotation(action, "priority")
    role = role_of(action.args[0]) if action.args else {}
    return ActionRequest(
        uuid=uuidlib.uuid4().hex, name=action.functor, args=args,
        robot="" if role else str(args[0]) if args else "",
        goal=str(args[1]) if len(args) > 1 else "",
        priority=priority if isinstance(priority, int) else 0,
        literal=term_str(Struct(action.functor, action.args)), role=role,
    )


def role_of(term: Any) -> dict[str, Any]:
    """The wire form of a role term (`any([uav, camera])`, `any([camera], at(Lat, Lon))`);
    {} for anything else (a robot id)."""
    if not (isinstance(term, Struct) and term.functor == ROLE_FUNCTOR and not term.neg
            and len(term.args) in (1, 2)):
        return {}
    caps = term.args[0]
    names = [c.functor for c in caps if isinstance(c, Struct)] \
        if isinstance(caps, tuple) and all(isinstance(c, Struct) and not c.args and not c.neg
                                           for c in caps) else None
    if not names:
        raise MrssError(f"{term_str(term)}: a role's first argument is a non-empty list of "
                        "capability names, e.g. any([uav, camera])")
    role: dict[str, Any] = {CAPABILITIES: names}
    if len(term.args) == 2:
        place = term.args[1]
        values = [v for v in place.args if isinstance(v, int | float)
                  and not isinstance(v, bool)] if isinstance(place, Struct) else []
        if not (isinstance(place, Struct) and place.functor == PLACE_FUNCTOR
                and len(place.args) == 2 and len(values) == 2):
            raise MrssError(f"{term_str(term)}: a role's place is at(Lat, Lon), numbers")
        role[NEAR] = [float(values[0]), float(values[1])]
    return role


def goal_management_control(action: Struct) -> ActionControl:
    """The ActionControl of `rcl_goal_management(Command, Target)` (or `(C, Kind, T)`)."""
    args = action.args
    if len(args) not in (2, 3):
        raise MrssError(f"{GOAL_MANAGEMENT} takes (Command, Target) or (Command, Kind, "
                        f"Target), not {term_str(action)}")
    command = str(plain_arg(args[0]))
    if command not in CONTROL_COMMANDS:
        raise MrssError(f"{GOAL_MANAGEMENT}: unknown command {command!r}")
    if len(args) == 3:
        kind, target = str(plain_arg(args[1])), plain_arg(args[2])
    else:
        target_term = args[1]
        kind = "goal"
        if (isinstance(target_term, Struct) and len(target_term.args) == 1
                and target_term.functor in CONTROL_TARGETS):
            kind, target = target_term.functor, plain_arg(target_term.args[0])
        else:
            target = plain_arg(target_term)
    if kind not in CONTROL_TARGETS:
        raise MrssError(f"{GOAL_MANAGEMENT}: unknown target kind {kind!r}")
    return ActionControl(command=ControlCommand(command), target=str(target),
                         target_kind=ControlTarget(kind))
