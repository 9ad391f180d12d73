"""Enter on a row opens its detail screen (`mrss.tui.details`): an action (or, on the
mission panel, the goal's latest action), a component, a robot. A base of `MrssApp`."""

from __future__ import annotations

from collections.abc import Callable

from textual.app import App

from mrss.tui.details import ActionDetail, ComponentDetail, DetailScreen, RobotDetail
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


class DetailKeys(App[None]):
    """Opens the detail screens; the models are the app's."""

    actions: ActionsModel
    goals: GoalsModel
    robots: RobotsModel
    supervision: SupervisionModel
    clock: Callable[[], float]
    restart_budget: tuple[int, float] | None

    def _say(self, text: str, *, error: bool = False) -> None:
        raise NotImplementedError

    def on_strip_table_row_selected(self, event: StripTable.RowSelected) -> None:
        """Enter on a row: the detail screen of that action, goal, component or robot."""
        key = event.row_key
        table = event.table
        screen: DetailScreen | None = None
        if isinstance(table, ActionsTable):
            screen = ActionDetail(self.actions, key, clock=self.clock)
        elif isinstance(table, MissionPanel):
            last = self.goals.last_action(key, self.actions)
            if last is None:
                self._say(f"goal {key} has no action yet")
                return
            screen = ActionDetail(self.actions, last.uuid, clock=self.clock)
        elif isinstance(table, SupervisionTable):
            screen = ComponentDetail(self.supervision, key, self.query_one(LogPane).lines_text,
                                     self.restart_budget, clock=self.clock)
        elif isinstance(table, RobotsTable):
            screen = RobotDetail(self.robots, key, clock=self.clock)
        if screen is not None:
            event.stop()
            self.push_screen(screen)

