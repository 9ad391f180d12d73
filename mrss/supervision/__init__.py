"""Supervision: OTP-style restart policies for component processes and pykka actors.

Processes: `ProcessSupervisor` (the root of `mrss supervise`) runs component processes
(`mrss.runtime`), each started with a `StartContext`. Actors: `ActorSupervisor` runs
`SupervisedActor`s, nested as deep as needed. Both decide with the same
`RestartPolicy`. See docs/supervision.md.
"""

from mrss.supervision.actors import ActorSupervisor
from mrss.supervision.children import ComponentStart, ProcessSettings
from mrss.supervision.events import EventLog, SupEvents
from mrss.supervision.policy import Action, Decision, RestartPolicy
from mrss.supervision.process import ProcessSupervisor
from mrss.supervision.reason import Cause, ExitReason
from mrss.supervision.spec import (
    KILL,
    Backoff,
    ChildKind,
    ChildSpec,
    OnExceeded,
    Restart,
    Strategy,
    SupervisorSpec,
)
from mrss.supervision.start import StartContext
from mrss.supervision.status import ChildState, ChildStatus, Outcome
from mrss.supervision.supervised import (
    ActorContext,
    ActorStart,
    Escalation,
    LinkDown,
    SupervisedActor,
    actor_child,
)

__all__ = [
    "KILL", "Action", "ActorContext", "ActorStart", "ActorSupervisor", "Backoff", "Cause",
    "ChildKind", "ChildSpec", "ChildState", "ChildStatus", "ComponentStart", "Decision",
    "Escalation", "EventLog", "ExitReason", "LinkDown", "OnExceeded", "Outcome",
    "ProcessSettings", "ProcessSupervisor", "Restart", "RestartPolicy", "Strategy",
    "StartContext", "SupEvents", "SupervisedActor", "SupervisorSpec", "actor_child",
]
