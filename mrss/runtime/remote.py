"""Operator commands for the root supervisor over the bus: `ctl.tree`, `ctl.fault`, `ctl.stop`.

The TUI runs in another process than `mrss supervise`, so it cannot call
`ProcessSupervisor.tree()` or `mrss.supervision.faults` itself. `RemoteControl`
subscribes the root to two `Command`s and answers on the bus:

- `Command("tree", target="" | root name)` -> a `SupEvent(event="tree")` on `sup.tree`,
  `detail.tree` = `ProcessSupervisor.tree().to_dict()`;
- `Command("fault", target=component, args={"fault": "kill" | "term" | "hang" | "crash" |
  "slow_start", "seconds": S})` -> `faults.inject`, and a `LogRecord` on `log.<root>`
  saying what was done or why it was refused (unknown child, not running, bad fault);
- `Command("stop", target=root name)` -> `request_stop()`: the same ordered stop as
  Ctrl-C (a `LogRecord` says who asked). A stop naming another system is refused.

Both pass the project's roles first (`mrss.runtime.operator_guard`): with users
configured, a fault needs a commander's credential (`CommandKind.FAULT`), and so does a
stop (`CommandKind.STOP`); a refusal is logged (on the bus too) and counted.

Only process faults on the root's own children are wired; actor faults need the
component's in-process actor supervisor and are not reachable from here.
"""

from __future__ import annotations

import logging
import os

from mrss.auth.roles import CommandKind
from mrss.bus import BusEndpoints, Subscriber
from mrss.errors import MrssError
from mrss.messages import Command, Envelope, LogRecord, SupEvent, SupEventKind
from mrss.runtime.operator_guard import LOCAL, OperatorGuard
from mrss.supervision import faults
from mrss.supervision.events import Publish
from mrss.supervision.process import ProcessSupervisor

log = logging.getLogger("mrss.runtime.remote")

TREE_EVENT = SupEventKind.TREE


def tree_event(sup: ProcessSupervisor) -> SupEvent:
    """The live tree of `sup` as a `sup.tree` event."""
    return SupEvent(event=TREE_EVENT, child=sup.name, supervisor=sup.name, pid=os.getpid(),
                    detail={"tree": sup.tree().to_dict()}, node=sup.events.node)


class RemoteControl:
    """Answers `ctl.tree`, executes `ctl.fault` and `ctl.stop` for one root supervisor."""

    def __init__(self, sup: ProcessSupervisor, endpoints: BusEndpoints,
                 publish: Publish, operators: OperatorGuard | None = None) -> None:
        self.sup = sup
        self.operators = operators or OperatorGuard(None, log)
        self._publish = publish
        self._sub = Subscriber(endpoints, prefixes=["ctl.tree", "ctl.fault", "ctl.stop"],
                               name="supervisor-ctl")

    def start(self) -> RemoteControl:
        self._sub.start(self.handle)
        return self

    def close(self) -> None:
        self._sub.close()

    def handle(self, env: Envelope) -> None:
        """One command from the bus; anything unexpected is logged and ignored."""
        body = env.body
        if not isinstance(body, Command):
            return
        if body.command == "tree" and body.target in ("", self.sup.name):
            self._publish(tree_event(self.sup))
        elif body.command == "fault":
            verdict = self.operators.check_envelope(env, CommandKind.FAULT,
                                                    f"ctl.fault {body.target}")
            if verdict.ok:
                self._fault(body, verdict.who if verdict.who != LOCAL else env.src)
        elif body.command == "stop":
            verdict = self.operators.check_envelope(env, CommandKind.STOP,
                                                    f"ctl.stop {body.target}")
            if not verdict.ok:
                return
            if body.target != self.sup.name:
                self._say("WARNING", f"stop of {body.target!r} from {env.src} refused: "
                          f"this is {self.sup.name!r}")
                return
            by = env.src if verdict.who in (LOCAL, env.src) else f"{verdict.who} ({env.src})"
            self._say("WARNING", f"stopping {self.sup.name}: asked by {by}")
            self.sup.request_stop()

    def _fault(self, cmd: Command, sender: str) -> None:
        if self.sup.events.node and self.sup.tree().find(cmd.target) is None:
            return  # one node of several: the root of the target's node answers
        fault = cmd.args.get("fault")
        seconds = cmd.args.get("seconds", 5.0)
        try:
            if not isinstance(fault, str) or fault not in faults.PROCESS_FAULTS:
                raise MrssError(f"unknown fault {fault!r}; known: "
                                f"{', '.join(faults.PROCESS_FAULTS)}")
            if not isinstance(seconds, (int, float)) or isinstance(seconds, bool):
                raise MrssError(f"seconds must be a number, not {seconds!r}")
            pid = self.sup.pid_of(cmd.target)  # SupervisionError for an unknown child
            faults.inject(self.sup, fault, cmd.target, seconds=float(seconds))
        except (MrssError, OSError) as exc:
            self._say("WARNING", f"fault {fault!r} on {cmd.target!r} from {sender} "
                      f"refused: {exc}")
            return
        self._say("WARNING", f"fault {fault} injected into {cmd.target} (pid {pid}) "
                  f"by {sender}")

    def _say(self, level: str, message: str) -> None:
        log.log(logging.getLevelName(level), "%s", message)
        try:
            self._publish(LogRecord(component=self.sup.name, level=level, message=message))
        except Exception:  # a broken bus must not break supervision
            log.exception("cannot publish: %s", message)
