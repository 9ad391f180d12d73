"""Taking a robot out of service from the dashboard, and back: what is sent, what is asked.

`d` on the robots table: a robot in service is decommissioned (`ctl.decommission`, the
RCL's command: the robot is unavailable with cause `decommissioned`, its open actions
fail with it, and each task addressed to a role it held goes to another robot); a
decommissioned one is recommissioned (`ctl.recommission`: available again, it may win
new tasks, never one it already handed on). Both ask first, naming what changes: the
tasks handed on, the actions addressed to the robot by name that fail. They go to the
RCL directly, as the operator's command on the fleet (the agent sees the tasks'
`reassigned(Task, From, To)` and the robot's unavailability, as for any loss).
"""

from __future__ import annotations

from mrss.messages import Command
from mrss.tui.events import SendRequested
from mrss.tui.models.actions import ActionsModel
from mrss.tui.models.robots import RobotsModel
from mrss.tui.models.tasks import task_label
from mrss.tui.operator import OperatorError

SHOWN = 6  # tasks or actions named in the question (the rest counted)


def command(robot: str, out: bool) -> Command:
    """`ctl.decommission` (out) or `ctl.recommission` for `robot`."""
    if not robot:
        raise OperatorError("no robot selected")
    return Command(command="decommission" if out else "recommission", target=robot)


def request(robot: str, *, robots: RobotsModel, actions: ActionsModel) -> SendRequested:
    """The request `d` makes for `robot`: its question names what it changes (the tasks
    among its open actions: `actions.tasks`)."""
    tasks = actions.tasks
    known = robots.robots.get(robot)
    out = not (known is not None and known.decommissioned)
    if not out:
        return SendRequested(
            command(robot, False), f"recommission {robot}",
            confirm=f"Recommission {robot}: back in service?",
            details=[f"{robot} is available again: it may be awarded tasks addressed to "
                     "a role (never one it already handed on).",
                     "Actions addressed to it by name may be sent to it again."])
    open_on = [v for v in actions.newest_first()
               if v.robot == robot and v.state and not v.terminal]
    handed = [v for v in open_on if v.uuid in tasks.tasks]
    failing = [v for v in open_on if v.uuid not in tasks.tasks]
    details = [f"{robot} becomes unavailable (cause decommissioned) until recommissioned "
               "with d."]
    details.append(_listed("tasks handed to other robots (addressed to a role)",
                           [task_label(v.name, v.goal, v.uuid) for v in handed]))
    details.append(_listed("actions that fail (addressed to it by name; the agent decides)",
                           [task_label(v.name, v.goal, v.uuid) for v in failing]))
    return SendRequested(command(robot, True), f"decommission {robot}",
                         confirm=f"Decommission {robot}: take it out of service?",
                         details=details)


def _listed(what: str, items: list[str]) -> str:
    if not items:
        return f"{what}: none known"
    more = f", and {len(items) - SHOWN} more" if len(items) > SHOWN else ""
    return f"{what}: {', '.join(items[:SHOWN])}{more}"
