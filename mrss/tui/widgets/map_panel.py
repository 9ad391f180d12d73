"""MapPanel: the robots, their tracks and the world model's objects on a braille map.

Until the operator zooms or pans, the view fits everything known; `0` goes back to that.
`f` cycles "follow": the view stays centred on one robot, then the next, then none;
the title then says how far along its plan it is (`plan 5/12` waypoints reached).

Pointing and drawing (`models/sketch.py`): space shows the cursor (`┼`) at the view's
centre, and the arrows then move it a cell at a time (panning again once it is hidden);
Enter puts a vertex where it is, Backspace takes the last one off, Delete clears them.
`P` makes the cursor (or the one vertex) a point, `R` a circle (centre: the first vertex,
edge: the cursor or the second vertex), `Z` a polygon of the vertices; a good shape is
posted as `ShapeDrawn` (the app opens a command whose form has such a field, pre-filled),
a bad one (a polygon that crosses itself, too many vertices) is said and nothing opens.
`l` lists the robots in the cursor's cell (several robots at one spot show as
`uav1+2`).

The title (scale, mode) is known only once the map is drawn; it is set only when it
changed, as setting it makes Textual paint the panel again (a frame of its own).
"""

from __future__ import annotations

from typing import ClassVar

from rich.text import Text
from textual.binding import Binding, BindingType
from textual.message import Message
from textual.widget import Widget

from mrss.config.operator_commands import FieldType
from mrss.tui.events import Note
from mrss.tui.models.braille import BrailleCanvas
from mrss.tui.models.geo import DOTS_X, DOTS_Y, Viewport
from mrss.tui.models.map import MapModel, ObjectsLayer
from mrss.tui.models.sketch import Sketch, SketchError
from mrss.tui.widgets.border_text import set_border_title

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
        Binding("space", "cursor", "Cursor"),
        Binding("enter", "vertex", "Vertex", show=False),
        Binding("backspace", "undo", "Undo vertex", show=False),
        Binding("delete", "clear", "Clear drawing", show=False),
        Binding("P", "shape('point')", "Point", show=False),
        Binding("R", "shape('circle')", "Circle", show=False),
        Binding("Z", "shape('polygon')", "Polygon", show=False),
        Binding("l", "robots_here", "Robots here", show=False),
    ]

    class ShapeDrawn(Message):
        """A point, circle or polygon drawn on the map, as a command field's text."""

        def __init__(self, kind: FieldType, text: str) -> None:
            super().__init__()
            self.kind = kind
            self.text = text

    def __init__(self, model: MapModel, *, id: str | None = None) -> None:
        super().__init__(id=id)
        self.model = model
        self.view = Viewport()
        self.auto_fit = True
        self.following: str | None = None
        self.sketch = Sketch()
        #: (width, height, rows) last painted, and drawn by `redraw` for the next paint
        self._drawn: tuple[int, int, list[list[tuple[str, str]]]] | None = None
        self._pending: tuple[int, int, list[list[tuple[str, str]]]] | None = None
        self._layer = ObjectsLayer()  # the world objects as this view last drew them

    def _canvas_size(self) -> tuple[int, int]:
        size = self.content_size
        return max(1, size.width), max(1, size.height)

    def redraw(self) -> None:
        """What the map shows may have changed (a drain): repaint it only if it did. Most
        drains move a robot by less than a dot (`mrss bench tui`: 19 of 21 were drawn
        the same), and a repaint of the map is the dashboard's dearest."""
        width, height = self._canvas_size()
        rows = self._rows(width, height)
        self._retitle(width)
        if (width, height, rows) == self._drawn:
            return
        self._pending = (width, height, rows)
        self.refresh()

    def _rows(self, width: int, height: int) -> list[list[tuple[str, str]]]:
        """The canvas as the view shows it now (the view follows or fits first)."""
        if self.following is not None and self.following in self.model.robots:
            mark = self.model.robots[self.following]
            self.view.centre_on(mark.lat, mark.lon)
        elif self.auto_fit:
            self.view.fit(self.model.points(), width, height)
        canvas = self.model.draw(self.view, width, height, self._layer)
        self._draw_sketch(canvas, width, height)
        return canvas.rows()

    def render(self) -> Text:
        width, height = self._canvas_size()
        pending, self._pending = self._pending, None
        if pending is not None and pending[:2] == (width, height):
            rows = pending[2]  # just drawn by `redraw`
        else:
            rows = self._rows(width, height)
        self._drawn = (width, height, rows)
        text = Text(no_wrap=True, overflow="crop")
        for i, row in enumerate(rows):
            if i:
                text.append("\n")
            for run, style in row:
                text.append(run, style)
        self._retitle(width)
        return text

    def _retitle(self, width: int) -> None:
        """Set the title for the map just drawn, if it changed (a repaint comes)."""
        mode = (f"following {self.following}" if self.following
                else "fit" if self.auto_fit else "free")
        plan = self.model.plans.get(self.following or "")
        if plan is not None:  # how far the followed robot is along its plan
            mode += f" · plan {plan.next}/{len(plan.waypoints)}"
        empty = "" if self.model.points() else " · no positions yet"
        if self.model.world_error:
            empty += f" · world model: {self.model.world_error[:40]}"
        drawing = ""
        if self.sketch.cursor is not None:
            lat, lon = self.sketch.cursor
            drawing = f" · cursor {lat:.5f},{lon:.5f} · {len(self.sketch.vertices)} vertices"
        title = (f"Map {self.view.describe(width)} · {mode}{empty}{drawing} "
                 f"({'↑↓←→ Enter P R Z l Del' if drawing else '+ - ← → f 0'})")
        set_border_title(self, title)

    def _draw_sketch(self, canvas: BrailleCanvas, width: int, height: int) -> None:
        sketch = self.sketch
        if sketch.vertices:
            dots = [self.view.to_dots(lat, lon, width, height) for lat, lon in sketch.vertices]
            tail = [self.view.to_dots(*sketch.cursor, width, height)] if sketch.cursor else []
            canvas.polyline(dots + tail, "bold white")
        if sketch.cursor is not None:
            col, row = self.view.to_cell(*sketch.cursor, width, height)
            canvas.glyph(col, row, "┼", "bold reverse")

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
        if self.sketch.cursor is not None:  # the cursor moves, a cell at a time
            x, y = self.view.to_dots(*self.sketch.cursor, width, height)
            self.sketch.cursor = self.view.to_latlon(x + right * DOTS_X, y + down * DOTS_Y,
                                                     width, height)
            self.refresh()
            return
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

    # -- pointing and drawing ---------------------------------------------------------------
    def action_cursor(self) -> None:
        """Show the cursor at the view's centre, or hide it (the vertices stay)."""
        if self.sketch.cursor is None:
            width, height = self._canvas_size()
            self.auto_fit = False
            self.following = None
            self.sketch.cursor = self.view.to_latlon(width * DOTS_X / 2 + 1,
                                                     height * DOTS_Y / 2 + 2, width, height)
        else:
            self.sketch.cursor = None
        self.refresh()

    def action_vertex(self) -> None:
        try:
            count = self.sketch.add()
        except SketchError as exc:
            self.post_message(Note(f"map: {exc}", error=True))
            return
        self.post_message(Note(f"map: vertex {count} at {self.sketch.vertices[-1][0]:.5f},"
                               f"{self.sketch.vertices[-1][1]:.5f} (P point, R circle, "
                               "Z polygon)"))
        self.refresh()

    def action_undo(self) -> None:
        self.sketch.undo()
        self.refresh()

    def action_clear(self) -> None:
        """Delete: the vertices go; with none left, the cursor too."""
        if self.sketch.vertices:
            self.sketch.clear()
        else:
            self.sketch.cursor = None
        self.refresh()

    def action_shape(self, kind: str) -> None:
        """Make the drawing a point, circle or polygon and hand it to a command's form."""
        field = FieldType(kind)
        make = {FieldType.POINT: self.sketch.point, FieldType.CIRCLE: self.sketch.circle,
                FieldType.POLYGON: self.sketch.polygon}[field]
        try:
            text = make()
        except SketchError as exc:
            self.post_message(Note(f"map: not a {kind}: {exc}", error=True))
            return
        self.post_message(self.ShapeDrawn(field, text))

    def robots_here(self) -> list[str]:
        """The robots in the cursor's cell (or, without a cursor, at the busiest spot)."""
        width, height = self._canvas_size()
        cells = self.model.robots_by_cell(self.view, width, height)
        if self.sketch.cursor is not None:
            marks = cells.get(self.view.to_cell(*self.sketch.cursor, width, height), [])
        else:
            marks = max(cells.values(), key=len, default=[])
        return [m.robot for m in marks]

    def action_robots_here(self) -> None:
        robots = self.robots_here()
        where = "under the cursor" if self.sketch.cursor is not None else "at the busiest spot"
        self.post_message(Note(f"map: {len(robots)} robot{'s' if len(robots) != 1 else ''} "
                               f"{where}: {', '.join(robots) or 'none'}"))
