"""Where each robot stands for the RCL: available or not, and why; teleop; its link.

One object of the RCL core (mrss/actors/rcl/core.py), holding what it knows of each
robot's availability; it reaches robot actors and ends actions through the core's
`Routes`, and reads the open actions under their lock. Rules:
- a robot is unavailable for one cause at a time (`lifecycle.EndCause`): its link lost
  (`link_lost`), its failsafe taken (`failsafe`), or its actor quarantined
  (`quarantined`); new requests for it are refused with that cause, so the agent can
  tell a robot to wait for from a broken one;
- a robot reached through a node (`node` in its table, mrss.config.nodes) is unavailable with
  cause `node_down` while that node is lost (`sup.node_down` from the bus proxy), its
  open actions failing with it; `sup.node_up` makes it available again;
- a link going down fails the robot's open actions (`link_down`, or `failsafe` when the
  robot overtook the command); a link coming back makes it available again, unless
  something else (a quarantine) holds it; a quarantine fails its open actions, a
  release makes it available;
- the operator decommissions a robot (`decommission`, the `ctl.decommission` command):
  unavailable with cause `decommissioned`, its open actions failing with it (a task
  addressed to a role goes to another robot); `ctl.recommission` makes it available.
  Journaled first: a decommissioned robot stays out after any restart of the RCL (or
  of the whole system) until it is recommissioned, and a link or node lost meanwhile
  does not replace that cause;
- at start, a robot whose link is not up yet is unavailable until the link first
  reports up (`await_first_reports`): a link starts down and says nothing until its
  first heartbeat or telemetry, so without this a robot that never came back after an
  RCL restart would look available and be given tasks. Past its link's timeout without
  a first report it is lost like a link going down (`first_reports_due`): its open
  actions fail with `link_down` and its tasks addressed to a role go to others;
- a robot whose own `status` says it is teleoperated (`"teleop": true`: switched at the
  robot, or by a project's skill, not by the RCL's `teleop`) is given no task addressed
  to a role until its status says otherwise (`teleoperated`); actions addressed to it
  by name are not refused for it (its skills decide);
- every change, and every restart of a requester, is announced as a `RobotState`
  (level-triggered: availability, reason, link, teleop).
"""

from __future__ import annotations

import logging
from collections.abc import Callable, Mapping
from typing import Any

from mrss.actors.rcl import lifecycle as lc
from mrss.actors.rcl.journal import ActionJournal
from mrss.actors.rcl.open_actions import OpenActions, Routes
from mrss.actors.rcl.resources import ResourceBroker
from mrss.actors.rcl.robot import SetTeleop
from mrss.errors import ActionError
from mrss.links.failsafe import LinkDownCause, link_down_cause
from mrss.messages import (
    ActionState,
    FailureCause,
    LinkState,
    Message,
    RobotState,
    SupEvent,
)
from mrss.supervision import events as ev

log = logging.getLogger("mrss.rcl")

LINK_DOWN = "link down"  # how an unavailable robot's reason starts when its link is lost
NODE_DOWN = "node down"  # ... when the node it is reached through is lost
DECOMMISSIONED = "decommissioned by the operator"  # ... when the operator took it out
FIRST_REPORT = "waiting for its link's first report"  # ... at start, until its link is up
IN_TELEOP = "in teleop (the robot's status says so)"  # ... a robot teleoperated, not by the RCL
#: The attributes by which a link says how long its robot may be silent (MAVLink, MQTT,
#: HTTP), and the wait for a first report of a link that says none.
SILENCE_TIMEOUTS = ("heartbeat_timeout", "telemetry_timeout", "timeout")
DEFAULT_SILENCE = 3.0
LINK_CAUSES = (lc.EndCause.LINK_LOST, lc.EndCause.FAILSAFE)


class RobotAvailability:
    """Availability, teleop and link state of the robots (the rules of the module)."""

    def __init__(self, links: dict[str, Any], journal: ActionJournal, broker: ResourceBroker,
                 publish: Callable[[Message], object], actions: OpenActions,
                 routes: Routes) -> None:
        self.links, self.journal, self.broker, self.publish = links, journal, broker, publish
        self.actions, self.routes = actions, routes
        self.robot_nodes: dict[str, str] = {}  # robot -> the node it is reached through
        self.stopping = False  # the RCL is stopping: its own links closing are no news
        self._unavailable: dict[str, str] = {}
        self._unavailable_cause: dict[str, lc.EndCause] = {}  # what a request is refused as
        self._awaiting: dict[str, tuple[float, float]] = {}  # robot -> (deadline, timeout)
        self.on_change: Callable[[], None] = lambda: None  # a robot's state changed
        self.on_teleop: Callable[[str, bool], None] = lambda _r, _on: None  # told an actor
        #: a robot awaited at start reported up, or its wait is over (it is lost)
        self.on_settled: Callable[[str], None] = lambda robot: None

    def refusal(self, robot: str) -> tuple[str, lc.EndCause] | None:
        """Why a new action for `robot` is refused now (reason, cause); None: it is not."""
        with self.actions.lock:
            reason = self._unavailable.get(robot)
            return None if reason is None else (reason, self._unavailable_cause[robot])

    def unavailable(self) -> dict[str, str]:
        """robot -> why a new action for it is refused now, of every such robot."""
        with self.actions.lock:
            return dict(self._unavailable)

    def teleoperated(self) -> dict[str, str]:
        """robot -> IN_TELEOP, of every robot whose link says it is teleoperated now
        (`reports_teleop`; a project's link without it never is)."""
        found = {}
        for robot, link in self.links.items():
            reports = getattr(link, "reports_teleop", None)
            if callable(reports) and reports() is True:
                found[robot] = IN_TELEOP
        return found

    def announce_robots(self) -> None:
        """Publish every robot's state (availability, link, teleop): level-triggered, so a
        restarted reasoner or dashboard knows where each robot stands."""
        teleop = self.journal.teleop_robots()
        for robot in self.links:
            self._robot_state(robot, teleop=robot in teleop)

    def set_teleop(self, robot: str, on: bool) -> None:
        """Teleop on suspends every action of `robot`; off resumes them from progress."""
        if robot not in self.links:
            raise ActionError(f"teleop for unknown robot {robot!r}")
        self.journal.set_teleop(robot, on)
        self.on_teleop(robot, on)  # the bid board knows it before the actor handles it
        self.routes.tell(robot, SetTeleop(on))
        self._robot_state(robot, teleop=on)

    def set_available(self, robot: str, available: bool, reason: str = "",
                      cause: lc.EndCause = lc.EndCause.REJECTED) -> None:
        """Mark `robot` (un)available; new actions for an unavailable robot are refused,
        with `cause` (a lost link, a quarantine: the agent may try again later)."""
        with self.actions.lock:
            before = self._unavailable.get(robot)
            if available:
                self._unavailable.pop(robot, None)
                self._unavailable_cause.pop(robot, None)
            else:
                self._unavailable[robot] = reason or "unavailable"
                self._unavailable_cause[robot] = cause
            changed = before != self._unavailable.get(robot)
        if changed:
            self._robot_state(robot)

    def await_first_reports(self, timeouts: Mapping[str, float], now: float) -> None:
        """At start, before the links' states are bound: each robot of `timeouts` (its
        link's silence timeout) is unavailable until its link first reports up, and lost
        if none came by `now` + that timeout (`first_reports_due`)."""
        for robot, timeout in timeouts.items():
            if robot not in self.links:
                continue
            with self.actions.lock:
                self._awaiting[robot] = (now + timeout, timeout)
            self.set_available(robot, False, f"{LINK_DOWN}: {FIRST_REPORT}",
                               lc.EndCause.LINK_LOST)

    def awaiting(self, robot: str) -> bool:
        """Whether `robot`'s link has not reported up since the start (and may yet)."""
        with self.actions.lock:
            return robot in self._awaiting

    def first_reports_due(self, now: float) -> None:
        """The robots whose link gave no first report within its timeout: lost."""
        with self.actions.lock:
            due = [(r, t) for r, (deadline, t) in self._awaiting.items() if now >= deadline]
            for robot, _ in due:
                del self._awaiting[robot]
        for robot, timeout in due:
            log.warning("robot %s: its link gave no first report within %g s of the start",
                        robot, timeout)
            self.link_state(robot, False, f"no first report within {timeout:g} s of the "
                            "RCL's start")
            self.on_settled(robot)

    def link_state(self, robot: str, up: bool, reason: str = "") -> list[str]:
        """The robot's link went down (robot unreachable) or came back.

        Down: the robot is marked unavailable and its open actions fail with the link's
        reason ("robot uav1 unreachable: no heartbeat for 3.0 s"). Up: available again,
        unless something else (a quarantine) still holds it. Returns the failed uuids.
        """
        if robot not in self.links:
            return []
        if self.stopping:  # our own links closing: the next start resumes the actions
            log.info("link of %s %s while the RCL stops: nothing failed", robot,
                     "up" if up else f"down ({reason})")
            return []
        with self.actions.lock:
            current = self._unavailable_cause.get(robot)
            first = up and self._awaiting.pop(robot, None) is not None
        if up:
            if current in LINK_CAUSES:  # not when something else (a quarantine) holds it
                self.set_available(robot, True)
            if first:
                self.on_settled(robot)
            return []
        if current in (lc.EndCause.NODE_DOWN, lc.EndCause.DECOMMISSIONED):
            return []  # the deeper cause (its actions failed with it); it stays
        self.set_available(robot, False, f"{LINK_DOWN}: {reason or 'no reason given'}",
                           lc.EndCause.FAILSAFE if link_down_cause(reason)
                           is LinkDownCause.FAILSAFE else lc.EndCause.LINK_LOST)
        targets = self.actions.of_robot(robot)
        why, cause = f"robot {robot} unreachable: {reason or 'link down'}", lc.EndCause.LINK_LOST
        if link_down_cause(reason) is LinkDownCause.FAILSAFE:
            why, cause = reason, lc.EndCause.FAILSAFE  # the robot overtook the command
        for uuid in targets:
            self.routes.control_one(uuid, lc.End(ActionState.FAILED, cause, why))
        return targets

    def decommission(self, robot: str, out: bool) -> list[str]:
        """The operator takes `robot` out of service (`out`) or back; the failed uuids."""
        if robot not in self.links:
            raise ActionError(f"decommission of unknown robot {robot!r} (known: "
                              f"{', '.join(sorted(self.links))})")
        with self.actions.lock:
            current = self._unavailable_cause.get(robot)
        self.journal.set_decommissioned(robot, out)  # first: it outlives any restart
        if not out:
            if current is lc.EndCause.DECOMMISSIONED:
                self.set_available(robot, True)
            return []
        self.set_available(robot, False, DECOMMISSIONED, lc.EndCause.DECOMMISSIONED)
        targets = self.actions.of_robot(robot)
        for uuid in targets:
            self.routes.control_one(uuid, lc.End(ActionState.FAILED, lc.EndCause.DECOMMISSIONED,
                                                 f"robot {robot} decommissioned by the operator"))
        return targets

    def restore_decommissioned(self) -> set[str]:
        """After a restart (before the robot actors start): the robots the operator took
        out of service are out again; `decommission` then fails what they still hold."""
        out = self.journal.decommissioned_robots() & set(self.links)
        for robot in sorted(out):
            log.info("robot %s stays decommissioned after the restart", robot)
            self.set_available(robot, False, DECOMMISSIONED, lc.EndCause.DECOMMISSIONED)
        return out

    def node_state(self, node: str, up: bool, reason: str = "") -> list[str]:
        """The node some robots are reached through was lost (`sup.node_down`) or is back.

        Lost: its robots are unavailable with cause `node_down` and their open actions
        fail with it (the agent sees `error(node_down)`). Back: available again, unless
        something else holds them. Repeats change nothing. Returns the failed uuids.
        """
        failed: list[str] = []
        for robot in [r for r, n in self.robot_nodes.items() if n == node and r in self.links]:
            with self.actions.lock:
                current = self._unavailable_cause.get(robot)
            if up:
                if current is lc.EndCause.NODE_DOWN:
                    self.set_available(robot, True)
                continue
            if current in (lc.EndCause.NODE_DOWN, lc.EndCause.DECOMMISSIONED):
                continue  # a repeat (sup.node_down is level-triggered), or out of service
            why = reason or f"node {node} lost"
            self.set_available(robot, False, f"{NODE_DOWN}: {why}", lc.EndCause.NODE_DOWN)
            targets = self.actions.of_robot(robot)
            for uuid in targets:
                self.routes.control_one(uuid, lc.End(
                    ActionState.FAILED, lc.EndCause.NODE_DOWN,
                    f"robot {robot} is reached through node {node}, which is lost: {why}"))
            failed += targets
        return failed

    def _robot_state(self, robot: str, teleop: bool | None = None) -> None:
        attrs: dict[str, Any] = {} if teleop is None else {"teleop": teleop}
        self.on_change()
        with self.actions.lock:
            reason = self._unavailable.get(robot, "")
            end = self._unavailable_cause.get(robot)
            link_down = end in LINK_CAUSES
        cause = FailureCause(lc.FAILURE_OF.get(end, "")) if reason and end is not None \
            else FailureCause.UNSPECIFIED
        try:
            self.publish(RobotState(robot=robot, available=not reason, reason=reason,
                                    link=LinkState.DOWN if link_down else LinkState.UP,
                                    attributes=attrs, cause=cause))
        except Exception as exc:
            log.error("publishing state of robot %s failed: %r", robot, exc)

    def publish_sup(self, event: Message) -> object:
        """Supervision events go out; a quarantine also fails the robot's open actions."""
        if isinstance(event, SupEvent) and event.child in self.links:
            if event.event == ev.QUARANTINE:
                self._quarantined(event.child, event.reason)
            elif event.event == ev.RELEASE:
                self.set_available(event.child, True)
        return self.publish(event)

    def _quarantined(self, robot: str, reason: str) -> None:
        self.set_available(robot, False, f"quarantined after repeated crashes ({reason})",
                           lc.EndCause.QUARANTINED)
        self.journal.drop_controls(robot)  # its actions fail below
        for entry in self.journal.open_actions():
            if entry.action.robot == robot:
                self.broker.forget_action(entry.action.uuid)
                self.routes.end_unrouted(entry.action, lc.End(
                    ActionState.FAILED, lc.EndCause.QUARANTINED,
                    f"robot {robot} quarantined: its actor keeps crashing ({reason})"))


def silence_timeout(link: Any) -> float:
    """How long `link`'s robot may be silent before the link is down (its own timeout)."""
    for name in SILENCE_TIMEOUTS:
        value = getattr(link, name, None)
        if isinstance(value, int | float) and not isinstance(value, bool) and value > 0:
            return float(value)
    return DEFAULT_SILENCE
