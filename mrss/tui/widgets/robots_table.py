"""RobotsTable: one row per robot (availability, link, teleop, latest telemetry); t = teleop,
g = follow it on the map, d = decommission / recommission it (`mrss.tui.decommission`)."""

from __future__ import annotations

from typing import ClassVar

from textual.binding import Binding, BindingType

from mrss.config.operator import OperatorCommand, teleop_payload
from mrss.tui import decommission, operator
from mrss.tui.events import MissionRequested, Note, SendRequested
from mrss.tui.models.actions import ActionsModel
from mrss.tui.models.goals import GoalsModel
from mrss.tui.models.robots import RobotsModel, RobotView
from mrss.tui.widgets.keyed_table import KeyedTable, Row, cell


def _yes_no(value: bool | None, yes: str, no: str) -> tuple[str, str]:
    if value is None:
        return "?", "dim"
    return (yes, "green") if value else (no, "red")


class RobotsTable(KeyedTable):
    """Robots with availability, link state and reason, teleop, position, battery, tank."""

    # What an operator watches first (can it work, how much is left, what is it doing)
    # comes first, so a narrow panel (a third of 120 or 160 columns) shows it.
    COLUMNS = (("robot", "robot"), ("available", "available"), ("link", "link"),
               ("battery", "battery"), ("tank", "tank"), ("goal", "goal"),
               ("teleop", "teleop"), ("position", "position"), ("data", "data age"),
               ("reason", "reason"))
    BINDINGS: ClassVar[list[BindingType]] = [
        Binding("t", "teleop", "Teleop on/off"),
        Binding("g", "show_on_map", "Follow on map"),
        Binding("d", "decommission", "Decommission / recommission"),
    ]

    def __init__(self, model: RobotsModel, goals: GoalsModel | None = None,
                 actions: ActionsModel | None = None, *, id: str | None = None) -> None:
        super().__init__(id=id)
        self.model = model
        self.goals = goals or GoalsModel()
        self.actions = actions or ActionsModel()  # and their tasks: what `d` names

    def refresh_rows(self, now: float) -> None:
        self.show([self._row(view, now) for view in self.model.robots.values()])

    def _row(self, view: RobotView, now: float) -> Row:
        available = ("decommissioned", "bold red") if view.decommissioned else \
            _yes_no(view.available, "yes", "no")
        link_style = {"up": "green", "down": "red"}.get(view.link, "dim")
        teleop = ("on", "bold yellow") if view.teleop else ("off" if view.teleop is False
                                                             else "", "")
        age = "" if view.data_ts is None else f"{max(0.0, now - view.data_ts):.0f}s"
        goal = self.goals.current_goal(view.robot)
        goal_text = ("", "") if goal is None else (
            goal.goal if goal.state.value == "running" else f"{goal.goal} ({goal.state.value})",
            "bold" if goal.state.value == "running" else "magenta")
        return view.robot, (
            cell(view.robot, "bold"), cell(*available), cell(view.link, link_style),
            cell(view.battery()), cell(view.tank()), cell(*goal_text), cell(*teleop),
            cell(view.position()), cell(age), cell(view.reason, "italic"))

    def action_teleop(self) -> None:
        robot = self.selected_key
        if robot is None:
            self.post_message(Note("no robot selected", error=True))
            return
        on = not self.model.robots[robot].teleop
        mission = getattr(self.app, "mission", None)
        if mission is not None and mission.config.has(OperatorCommand.TELEOP):
            self.post_message(MissionRequested(
                OperatorCommand.TELEOP, teleop_payload(robot, on),
                f"teleop {'on' if on else 'off'} for {robot}",
                confirm=f"Teleop {'ON' if on else 'OFF'} for {robot}?",
                details=[f"The agent is told: it {'suspends' if on else 'resumes'} "
                         f"{robot}'s goals and switches its mode."]))
            return
        actions = self.open_actions(robot)
        if on:
            confirm = f"Teleop ON for {robot}: take {robot} over by hand?"
            details = [f"{robot} stops executing its actions: {actions} suspended until "
                       "teleop is off.", "New actions for it wait as well."]
        else:
            confirm = f"Teleop OFF for {robot}: hand {robot} back to the system?"
            details = [f"Its suspended actions ({actions}) resume from their progress; "
                       f"{robot} may start moving at once."]
        details.append("Debug: this project declares no teleop command, so this goes to "
                       "the RCL directly, around the agent.")
        self.post_message(SendRequested(operator.teleop(robot, on),
                                        f"debug teleop {'on' if on else 'off'} for {robot}",
                                        confirm=confirm, details=details))

    def action_decommission(self) -> None:
        """`d`: take the selected robot out of service (its tasks go to others), or put
        a decommissioned one back; asks first."""
        robot = self.selected_key
        if robot is None:
            self.post_message(Note("no robot selected", error=True))
            return
        self.post_message(decommission.request(robot, robots=self.model,
                                               actions=self.actions))

    def action_show_on_map(self) -> None:
        """`g`: the map follows the selected robot (if it has sent a position)."""
        robot = self.selected_key
        follow = getattr(self.app, "map_follow", None)
        if robot is None or not callable(follow):
            self.post_message(Note("no robot selected", error=True))
        elif not follow(robot):
            self.post_message(Note(f"{robot} has sent no position yet", error=True))

    def open_actions(self, robot: str) -> str:
        """`2 actions (patrol, survey)` the dashboard knows open on `robot`."""
        counter = getattr(self.app, "open_actions_of", None)
        names: list[str] = counter(robot) if callable(counter) else []
        if not names:
            return "no known actions"
        return f"{len(names)} action{'s' if len(names) > 1 else ''} ({', '.join(names)})"
