"""Enter on a row opens its detail screen (`mrss.tui.details`): an action (or, on the
mission panel, the goal's latest action), a component, a robot."""

from __future__ import annotations

from collections.abc import Callable

from textual.app import App

from mrss.tui.details import ActionDetail, ComponentDetail, DetailScreen, RobotDetail
from mrss.tui.events import Say
from mrss.tui.models.actions import ActionsModel
from mrss.tui.models.goals import GoalsModel
from mrss.tui.models.robots import RobotsModel
from mrss.tui.models.supervision import SupervisionModel
from mrss.tui.widgets.actions_table import ActionsTable
from mrss.tui.widgets.log_pane import LogPane
from mrss.tui.widgets.mission_panel import MissionPanel
from mrss.tui.widgets.robots_table import RobotsTable
from mrss.tui.widgets.strip_table import StripTable
from mrss.tui.widgets.supervision_table import SupervisionTable


class RowDetails:
    """Opens the detail screen of a selected row on `app`, from the models (and, for a
    component, the app's `LogPane` lines); `say` reports a row with nothing to show."""

    def __init__(self, app: App[None], say: Say, *, actions: ActionsModel,
                 goals: GoalsModel, robots: RobotsModel, supervision: SupervisionModel,
                 restart_budget: tuple[int, float] | None,
                 clock: Callable[[], float]) -> None:
        self.app = app
        self.say = say
        self.actions = actions
        self.goals = goals
        self.robots = robots
        self.supervision = supervision
        self.restart_budget = restart_budget  # the root's (intensity, period), if known
        self.clock = clock

    def open_row(self, event: StripTable.RowSelected) -> None:
        """Enter on a row: the detail screen of that action, goal, component or robot."""
        key = event.row_key
        table = event.table
        screen: DetailScreen | None = None
        if isinstance(table, ActionsTable):
            screen = ActionDetail(self.actions, key, clock=self.clock)
        elif isinstance(table, MissionPanel):
            last = self.goals.last_action(key, self.actions)
            if last is None:
                self.say(f"goal {key} has no action yet")
                return
            screen = ActionDetail(self.actions, last.uuid, clock=self.clock)
        elif isinstance(table, SupervisionTable):
            screen = ComponentDetail(self.supervision, key,
                                     self.app.query_one(LogPane).lines_text,
                                     self.restart_budget, clock=self.clock)
        elif isinstance(table, RobotsTable):
            screen = RobotDetail(self.robots, key, clock=self.clock)
        if screen is not None:
            event.stop()
            self.app.push_screen(screen)
