"""MapPanel: the robots, their tracks and the world model's objects on a braille map.

Until the operator zooms or pans, the view fits everything known; `0` goes back to that.
`f` cycles "follow": the view stays centred on one robot, then the next, then none;
the title then says how far along its plan it is (`plan 5/12` waypoints reached).
"""

from __future__ import annotations

from typing import ClassVar

from rich.text import Text
from textual.binding import Binding, BindingType
from textual.widget import Widget

from mrss.tui.models.geo import Viewport
from mrss.tui.models.map import MapModel

ZOOM_STEP = 1.5
PAN_STEP = 0.25  # of the view's width or height


class MapPanel(Widget, can_focus=True):
    """The map; its border title says the scale and whom it follows."""

    DEFAULT_CSS = "MapPanel { height: 1fr; }"
    BINDINGS: ClassVar[list[BindingType]] = [
        Binding("plus,equals_sign", "zoom(1.5)", "Zoom in"),
        Binding("minus", "zoom(0.6667)", "Zoom out"),
        Binding("left", "pan(-1, 0)", "Pan left", show=False),
        Binding("right", "pan(1, 0)", "Pan right", show=False),
        Binding("up", "pan(0, -1)", "Pan up", show=False),
        Binding("down", "pan(0, 1)", "Pan down", show=False),
        Binding("f", "follow_next", "Follow robot"),
        Binding("0", "fit", "Fit all"),
    ]

    def __init__(self, model: MapModel, *, id: str | None = None) -> None:
        super().__init__(id=id)
        self.model = model
        self.view = Viewport()
        self.auto_fit = True
        self.following: str | None = None

    def _canvas_size(self) -> tuple[int, int]:
        size = self.content_size
        return max(1, size.width), max(1, size.height)

    def render(self) -> Text:
        width, height = self._canvas_size()
        if self.following is not None and self.following in self.model.robots:
            mark = self.model.robots[self.following]
            self.view.centre_on(mark.lat, mark.lon)
        elif self.auto_fit:
            self.view.fit(self.model.points(), width, height)
        canvas = self.model.draw(self.view, width, height)
        text = Text(no_wrap=True, overflow="crop")
        for i, row in enumerate(canvas.rows()):
            if i:
                text.append("\n")
            for run, style in row:
                text.append(run, style)
        self._retitle(width)
        return text

    def _retitle(self, width: int) -> None:
        mode = (f"following {self.following}" if self.following
                else "fit" if self.auto_fit else "free")
        plan = self.model.plans.get(self.following or "")
        if plan is not None:  # how far the followed robot is along its plan
            mode += f" · plan {plan.next}/{len(plan.waypoints)}"
        empty = "" if self.model.points() else " · no positions yet"
        if self.model.world_error:
            empty += f" · world model: {self.model.world_error[:40]}"
        self.border_title = f"Map {self.view.describe(width)} · {mode}{empty} (+ - ← → f 0)"

    def marker_cell(self, robot: str) -> tuple[int, int] | None:
        """The (column, row) of a robot's marker in the panel, None if unknown or outside."""
        mark = self.model.robots.get(robot)
        if mark is None:
            return None
        width, height = self._canvas_size()
        col, row = self.view.to_cell(mark.lat, mark.lon, width, height)
        return (col, row) if 0 <= col < width and 0 <= row < height else None

    def action_zoom(self, factor: float) -> None:
        self.auto_fit = False
        self.view.zoom(factor)
        self.refresh()

    def action_pan(self, right: float, down: float) -> None:
        width, height = self._canvas_size()
        self.auto_fit = False
        self.following = None
        self.view.pan(right * PAN_STEP, down * PAN_STEP, width, height)
        self.refresh()

    def follow(self, robot: str | None) -> None:
        """Keep `robot` in the middle (None: stop following)."""
        self.following = robot
        if robot is None:
            self.auto_fit = False
        self.refresh()

    def action_follow_next(self) -> None:
        robots = list(self.model.robots)
        if not robots:
            self.notify("no robot has sent a position yet", severity="warning")
            return
        if self.following not in robots:
            self.follow(robots[0])
        else:
            index = robots.index(self.following) + 1
            self.follow(robots[index] if index < len(robots) else None)

    def action_fit(self) -> None:
        self.following = None
        self.auto_fit = True
        self.refresh()
